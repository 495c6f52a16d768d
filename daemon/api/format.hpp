// The API's pure pieces: query filters, JSON bodies, Server-Sent Events framing
// and the Prometheus text. No sockets and no threads, so the unit tests drive
// them directly and the server code stays about transport.
#pragma once

#include "status/domain_status.hpp"
#include "status/usb_status.hpp"

#include "rsd_model/device.hpp"
#include "rsd_model/expected.hpp"
#include "rsd_model/participant.hpp"
#include "rsd_model/removal.hpp"

#include <array>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::api {

// Same shape as httplib::Params, without pulling httplib into the pure code.
using QueryParams = std::multimap<std::string, std::string>;

// Device documents may carry peer-supplied strings that are not valid UTF-8;
// nlohmann throws on those by default, which would turn one bad device into a
// failing endpoint. Replace them instead. Always one line (no indentation).
std::string dump(const nlohmann::json& doc);

// {"error": message, "status": status} with a trailing newline.
std::string error_body(int status, std::string_view message);
std::string_view status_text(int status);

// The one filter of the API, and so of every client (they pass theirs to the API and
// never filter again). Repeating a key ORs its values (?domain=0&domain=1); different
// keys AND. Values compare case-insensitively (product-line=d400, source=USB); a
// name matches when it is part of the device's name (name=d455).
struct DeviceFilter {
  std::set<int> domains;
  std::set<std::string> product_lines;  // lower case
  std::set<model::Source> sources;
  std::set<std::string> serials;    // lower case
  std::set<std::string> names;      // lower case, matched as a part of the name
  std::set<std::string> addresses;  // lower case, one of the server's (or remote-usb host's) addresses
  std::set<std::string> hosts;      // lower case, the name of a remote-usb camera's host
  std::optional<bool> in_use;       // a DDS camera with a client (model::Device::used)

  bool empty() const {
    return domains.empty() && product_lines.empty() && sources.empty() && serials.empty() && names.empty() &&
           addresses.empty() && hosts.empty() && !in_use;
  }
  // Reads the typed fields the table keeps (TableEntry::device): no parsing per request.
  bool matches(const model::Device& device) const;
};

// The rule of every route for query parameters: parameter names are exact (lower
// case), and a name the route does not take is a 400, so a typo such as ?domian=1 is
// never silently ignored and answered with every device. Returns the 400's message.
std::optional<std::string> check_params(std::string_view route, const QueryParams& params,
                                        const std::set<std::string>& allowed);

// Parses the filter keys (domain, product-line, source, serial, name, address, host, in-use); any other key must be
// in `also_allowed` (check_params). Returns the error message for a 400, or nothing.
std::optional<std::string> parse_device_filter(const QueryParams& params, DeviceFilter& out,
                                               const std::set<std::string>& also_allowed = {});

// ?fields=name,serial,server.addresses on GET /v1/devices: which keys of each device
// document a list carries (a dotted name is a key inside an object member), so a
// client that shows a few columns is sent and parses those, not every document whole
// (a cold `rs-discover list` of 100 cameras: bench/results/profile-cli-list.txt). The
// id always comes. Repeated, the lists join. Names: 1-64 characters of letters,
// digits, '-' and '_' per dotted part, at most 32 names; a name no device has is
// simply absent from the documents.
struct DeviceFields {
  std::vector<std::vector<std::string>> paths;  // each name split at its dots; empty: whole documents
  bool whole() const { return paths.empty(); }
};
std::optional<std::string> parse_device_fields(const QueryParams& params, DeviceFields& out);
// A device document as dump() writes it (the table's text) cut to `fields` and "id",
// as dump() would write that cut.
std::string project_device(std::string_view text, const DeviceFields& fields);

// /v1/participants' filter, by the same rule: ?domain= and ?state= (alive, gone),
// each repeatable.
struct ParticipantFilter {
  std::set<int> domains;
  std::set<model::ParticipantState> states;
  bool matches(const model::Participant& p) const;
};
std::optional<std::string> parse_participant_filter(const QueryParams& params, ParticipantFilter& out);

// A DDS domain id as the API accepts it: decimal 0..232, nothing else.
std::optional<int> parse_domain(std::string_view text);
// An SSE id / generation: decimal digits only, no sign, no overflow.
std::optional<std::uint64_t> parse_generation(std::string_view text);

// One SSE message. `data` may hold newlines: each line becomes its own data:
// field, as the SSE grammar requires. Ends with the blank line that dispatches it.
std::string sse_message(std::string_view event, std::optional<std::uint64_t> id,
                        std::string_view data);
// Whether an If-None-Match header value names `etag` (weakly, as RFC 9110 13.1.2
// says for GET): "*", or a comma-separated list of tags, W/ or not.
bool etag_matches(std::string_view if_none_match, std::string_view etag);
// The ETag of a /v1/devices list: the table's generation names the body, and a
// list taken before the first discovery ended is another body than one after.
std::string list_etag(std::uint64_t generation, bool complete);

// A comment line; clients ignore it, proxies see traffic on an idle stream.
std::string sse_comment(std::string_view text);

nlohmann::json domain_status_json(const DomainStatus& status);

// The process as Prometheus' client libraries report it (process_* metrics).
struct ProcessStats {
  double cpu_seconds = 0;          // user + system
  std::uint64_t resident_bytes = 0;
  std::uint64_t virtual_bytes = 0;
  std::uint64_t open_fds = 0;
  std::uint64_t max_fds = 0;
  double start_time_seconds = 0;  // since the Unix epoch
};

// /healthz "http": where HTTP listens (`bound_*`, "" and 0 without HTTP) against
// what the configuration names (`config_set`: the file or a flag named it; an empty
// host: "off"). Only a socket passed by systemd can disagree: the daemon binds the
// configured address itself otherwise. A configured host name (not an address) is
// compared by its port alone.
model::HttpHealth http_health(const std::string& config_host, int config_port, bool config_set,
                              const std::string& bound_host, int bound_port, bool from_systemd);

// The statuses the routes answer (rsd_api_requests_total shows each at 0 from the
// start). 408, 413, 414, 431 and the 503 at the connection limit are the
// connection loop's, counted apart (rsd_api_requests_rejected_total,
// rsd_api_timeouts_total, rsd_api_connections_refused_total).
inline constexpr int kRouteStatuses[] = {200, 304, 400, 404, 405, 409, 410, 421, 500, 503};

// Everything /metrics reports, gathered by the server at request time.
struct MetricsInput {
  std::optional<ProcessStats> process;  // nothing when /proc could not be read
  std::string version;
  std::vector<DomainStatus> domains;
  std::map<int, std::size_t> devices_per_domain;  // from the table; wins over DomainStatus::devices
  std::size_t devices_total = 0;
  std::uint64_t generation = 0;
  std::uint64_t events_sent = 0;
  std::size_t event_streams = 0;
  std::uint64_t event_streams_rejected = 0;
  std::uint64_t event_streams_dropped = 0;
  std::size_t connections = 0;
  std::uint64_t connections_refused = 0;
  std::uint64_t timeouts = 0;
  std::uint64_t rejected = 0;
  std::map<int, std::uint64_t> requests_by_status;
  std::optional<UsbStatus> usb;  // nothing when USB is turned off
  // The table's: cameras removed, by reason; added again while gone; gone kept; changes kept.
  std::array<std::uint64_t, model::kRemovalReasons.size()> removals{};
  std::uint64_t returns = 0;
  std::uint64_t flaps = 0;
  std::array<std::uint64_t, model::kHostVerdicts.size()> hosts{};  // lease-expired hosts judged
  std::size_t gone = 0;
  std::size_t history = 0;
  model::ExpectedReport expected;  // none expected: no rsd_expected_camera_present samples
};

// Prometheus text exposition format 0.0.4.
std::string render_metrics(const MetricsInput& in);
std::string prometheus_label_value(std::string_view raw);

}  // namespace rsd::api
