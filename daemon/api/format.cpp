#include "api/format.hpp"

#include "status/reasons.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <limits>
#include <type_traits>

namespace rsd::api {

std::string dump(const nlohmann::json& doc) {
  return doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string_view status_text(int status) {
  switch (status) {
    case 200: return "OK";
    case 304: return "Not Modified";  // as httplib spells it: the plain list's 304
    case 400: return "bad request";
    case 403: return "forbidden";
    case 404: return "not found";
    case 405: return "method not allowed";
    case 408: return "request timeout";
    case 409: return "conflict";
    case 413: return "payload too large";
    case 414: return "URI too long";
    case 416: return "range not satisfiable";
    case 431: return "request header fields too large";
    case 500: return "internal server error";
    case 503: return "service unavailable";
    default: return status >= 500 ? "server error" : "client error";
  }
}

std::string error_body(int status, std::string_view message) {
  nlohmann::json body = {{"error", std::string(message)}, {"status", status}};
  return dump(body) + "\n";
}

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(c >= 'A' && c <= 'Z' ? c + 32 : c); });
  return out;
}

bool all_digits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace

std::optional<int> parse_domain(std::string_view text) {
  // The length cap keeps "0000…0001" from counting as a valid id.
  if (!all_digits(text) || text.size() > 3) return std::nullopt;
  int value = 0;
  std::from_chars(text.data(), text.data() + text.size(), value);
  if (value > 232) return std::nullopt;
  return value;
}

std::optional<std::uint64_t> parse_generation(std::string_view text) {
  if (!all_digits(text)) return std::nullopt;
  std::uint64_t value = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

std::optional<std::string> check_params(std::string_view route, const QueryParams& params,
                                        const std::set<std::string>& allowed) {
  for (const auto& [key, value] : params) {
    if (allowed.contains(key)) continue;
    if (allowed.empty()) return std::string(route) + " takes no query parameters (got '" + key + "')";
    std::string known;
    for (const auto& k : allowed) known += (known.empty() ? "" : ", ") + k;
    return "unknown query parameter '" + key + "' (known: " + known + ")";
  }
  return std::nullopt;
}

std::optional<std::string> parse_device_filter(const QueryParams& params, DeviceFilter& out,
                                               const std::set<std::string>& also_allowed) {
  std::set<std::string> allowed = also_allowed;
  allowed.insert({"domain", "product-line", "source", "serial", "name", "address", "host", "in-use"});
  if (auto err = check_params("this route", params, allowed)) return err;
  for (const auto& [key, value] : params) {
    if (key == "domain") {
      auto d = parse_domain(value);
      if (!d) return "bad domain '" + value + "': expected an integer 0..232";
      out.domains.insert(*d);
    } else if (key == "product-line") {
      if (value.empty()) return std::string("empty product-line");
      out.product_lines.insert(lower(value));
    } else if (key == "source") {
      auto source = model::parse_source(lower(value));
      if (!source) return "bad source '" + value + "': expected dds, usb or remote-usb";
      out.sources.insert(*source);
    } else if (key == "in-use") {
      const std::string v = lower(value);
      if (v != "true" && v != "false") return "bad in-use '" + value + "': expected true or false";
      if (out.in_use && *out.in_use != (v == "true")) return std::string("in-use given both true and false");
      out.in_use = v == "true";
    } else if (key == "serial" || key == "name" || key == "address" || key == "host") {
      if (value.empty()) return "empty " + key;
      (key == "serial" ? out.serials : key == "name" ? out.names : key == "host" ? out.hosts : out.addresses)
          .insert(lower(value));
    }
  }
  return std::nullopt;
}

std::optional<std::string> parse_participant_filter(const QueryParams& params, ParticipantFilter& out) {
  if (auto err = check_params("/v1/participants", params, {"domain", "state"})) return err;
  for (const auto& [key, value] : params) {
    if (key == "domain") {
      auto d = parse_domain(value);
      if (!d) return "bad domain '" + value + "': expected an integer 0..232";
      out.domains.insert(*d);
    } else {
      auto state = model::parse_participant_state(lower(value));
      if (!state) return "bad state '" + value + "': expected alive or gone";
      out.states.insert(*state);
    }
  }
  return std::nullopt;
}

bool ParticipantFilter::matches(const model::Participant& p) const {
  return (domains.empty() || domains.contains(p.domain)) && (states.empty() || states.contains(p.state));
}

bool DeviceFilter::matches(const model::Device& device) const {
  if (!domains.empty() && (!device.domain || !domains.contains(*device.domain))) return false;
  if (!product_lines.empty() && (!device.product_line || !product_lines.contains(lower(*device.product_line))))
    return false;
  if (!sources.empty() &&
      std::none_of(sources.begin(), sources.end(), [&](model::Source s) { return device.seen_by(s); }))
    return false;
  if (!serials.empty() && (!device.serial || !serials.contains(lower(*device.serial)))) return false;
  if (!names.empty()) {
    const std::string name = device.name ? lower(*device.name) : "";
    if (std::none_of(names.begin(), names.end(), [&](const std::string& n) { return name.find(n) != std::string::npos; }))
      return false;
  }
  if (!addresses.empty()) {
    // A network camera's server, or the host sharing a remote-usb camera.
    const std::vector<std::string> none;
    const auto& mine = device.server && device.server->addresses ? *device.server->addresses
                       : device.host                             ? device.host->addresses
                                                                 : none;
    if (std::none_of(mine.begin(), mine.end(), [&](const std::string& a) { return addresses.contains(lower(a)); }))
      return false;
  }
  if (!hosts.empty() && (!device.host || !hosts.contains(lower(device.host->name)))) return false;
  if (in_use && device.used() != *in_use) return false;
  return true;
}

std::string sse_message(std::string_view event, std::optional<std::uint64_t> id,
                        std::string_view data) {
  std::string out;
  out.reserve(data.size() + event.size() + 40);
  if (!event.empty()) out.append("event: ").append(event).append("\n");
  if (id) out.append("id: ").append(std::to_string(*id)).append("\n");
  // Split on \n, \r\n and \r alike: all three end a line for an SSE parser.
  std::size_t start = 0;
  while (true) {
    std::size_t end = data.find_first_of("\r\n", start);
    out.append("data: ").append(data.substr(start, end == std::string_view::npos ? end : end - start)).append("\n");
    if (end == std::string_view::npos) break;
    start = end + ((data[end] == '\r' && end + 1 < data.size() && data[end + 1] == '\n') ? 2 : 1);
  }
  out.append("\n");
  return out;
}

std::string sse_comment(std::string_view text) {
  std::string out = ": ";
  for (char c : text) out.push_back(c == '\n' || c == '\r' ? ' ' : c);
  out.append("\n\n");
  return out;
}

nlohmann::json domain_status_json(const DomainStatus& s) { return model::to_json(s); }

namespace {

std::string host_port(const std::string& host, int port) {
  const bool v6 = host.find(':') != std::string::npos;
  return (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

// A numeric address in the form inet_ntop writes it ("::1" for "0:0::1"); nullopt
// for a host name.
std::optional<std::string> numeric_address(const std::string& host) {
  unsigned char raw[sizeof(in6_addr)];
  char text[INET6_ADDRSTRLEN] = {};
  for (int family : {AF_INET, AF_INET6})
    if (inet_pton(family, host.c_str(), raw) == 1 && inet_ntop(family, raw, text, sizeof text)) return text;
  return std::nullopt;
}

}  // namespace

model::HttpHealth http_health(const std::string& config_host, int config_port, bool config_set,
                              const std::string& bound_host, int bound_port, bool from_systemd) {
  model::HttpHealth h;
  h.from = from_systemd ? "systemd" : "config";
  h.listening = bound_port > 0 ? host_port(bound_host, bound_port) : "";
  h.configured = !config_set ? "" : config_host.empty() ? "off" : host_port(config_host, config_port);
  if (!from_systemd || !config_set) return h;
  if (config_host.empty()) {
    h.agrees = h.listening.empty();
  } else if (h.listening.empty() || config_port != bound_port) {
    h.agrees = false;
  } else {
    const auto address = numeric_address(config_host);
    h.agrees = !address || *address == bound_host;
  }
  return h;
}

std::string prometheus_label_value(std::string_view raw) {
  std::string out;
  for (char c : raw) {
    if (c == '\\') out += "\\\\";
    else if (c == '"') out += "\\\"";
    else if (c == '\n') out += "\\n";
    else out.push_back(c);
  }
  return out;
}

namespace {

class MetricWriter {
 public:
  void family(std::string_view name, std::string_view type, std::string_view help) {
    out_.append("# HELP ").append(name).append(" ").append(help).append("\n");
    out_.append("# TYPE ").append(name).append(" ").append(type).append("\n");
  }
  void sample(std::string_view name, const std::vector<std::pair<std::string, std::string>>& labels,
              std::uint64_t value) {
    out_.append(name);
    if (!labels.empty()) {
      out_.push_back('{');
      bool first = true;
      for (const auto& [k, v] : labels) {
        if (!first) out_.push_back(',');
        first = false;
        out_.append(k).append("=\"").append(prometheus_label_value(v)).append("\"");
      }
      out_.push_back('}');
    }
    out_.append(" ").append(std::to_string(value)).append("\n");
  }
  // A family of one label-less sample.
  template <typename Value>
  void single(std::string_view name, std::string_view type, std::string_view help, Value value) {
    family(name, type, help);
    if constexpr (std::is_floating_point_v<Value>) sample(name, static_cast<double>(value));
    else sample(name, {}, static_cast<std::uint64_t>(value));
  }
  void sample(std::string_view name, double value) {  // a label-less real number
    char text[64];
    std::snprintf(text, sizeof text, "%.6f", value);
    out_.append(name).append(" ").append(text).append("\n");
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

}  // namespace

std::string render_metrics(const MetricsInput& in) {
  MetricWriter w;
  w.family("rsd_build_info", "gauge", "Always 1; the daemon's version as a label.");
  w.sample("rsd_build_info", {{"version", in.version}}, 1);

  // Every configured domain shows up, with 0 when it has no devices, so an
  // alert on "devices == 0" works for a domain that never saw one.
  std::map<int, std::size_t> per_domain = in.devices_per_domain;
  for (const auto& d : in.domains) per_domain.try_emplace(d.domain, 0);
  // rsd_domain_devices is the per-domain count, named like the other rsd_domain_*
  // families; rsd_devices was its documented name in 0.1.0 and stays, the same
  // values, for one release so that dashboards can move.
  w.family("rsd_domain_devices", "gauge", "Devices in the table, by DDS domain (rsd_table_devices: all sources).");
  for (const auto& [domain, n] : per_domain) w.sample("rsd_domain_devices", {{"domain", std::to_string(domain)}}, n);
  w.family("rsd_devices", "gauge", "Deprecated, removed in the next release: use rsd_domain_devices (the same values).");
  for (const auto& [domain, n] : per_domain) w.sample("rsd_devices", {{"domain", std::to_string(domain)}}, n);

  w.family("rsd_table_devices", "gauge", "Devices in the table, all sources (DDS and USB).");
  w.sample("rsd_table_devices", {}, in.devices_total);
  w.family("rsd_table_generation", "gauge", "Generation of the last table event (the SSE id).");
  w.sample("rsd_table_generation", {}, in.generation);

  // The same condition as "complete" in /v1/devices: every domain's first discovery over.
  const bool complete =
      std::all_of(in.domains.begin(), in.domains.end(), [](const DomainStatus& d) { return d.complete; });
  w.family("rsd_table_complete", "gauge", "1 once every domain has finished its first discovery.");
  w.sample("rsd_table_complete", {}, complete ? 1 : 0);

  w.family("rsd_domain_up", "gauge", "1 when the domain's DDS side is running, by state.");
  for (const auto& d : in.domains)
    w.sample("rsd_domain_up", {{"domain", std::to_string(d.domain)}, {"state", std::string(to_string(d.state))}},
             d.state == DomainState::running ? 1 : 0);

  // One sample per domain each: a table, so a new counter is one line, not four.
  struct PerDomain {
    const char* name;
    const char* type;
    const char* help;
    std::uint64_t (*value)(const DomainStatus&);
  };
  const PerDomain per_domain_families[] = {
      {"rsd_messages_accepted_total", "counter", "device-info messages taken into the table.",
       [](const DomainStatus& d) { return d.accepted; }},
      {"rsd_messages_rejected_total", "counter", "device-info messages dropped, by reason.", nullptr},
      {"rsd_stopping_messages_total", "counter", "'stopping' messages honoured.",
       [](const DomainStatus& d) { return d.stopping; }},
      {"rsd_domain_rebuilds_total", "counter", "Times a domain's participant was rebuilt.",
       [](const DomainStatus& d) { return d.rebuilds; }},
      {"rsd_domain_refreshes_total", "counter",
       "Rebuilds the daemon made by itself to find a server lost without 'stopping'.",
       [](const DomainStatus& d) { return d.refreshes; }},
      {"rsd_domain_lost_servers", "gauge", "Servers lost without 'stopping' that are still looked for.",
       [](const DomainStatus& d) { return static_cast<std::uint64_t>(d.lost_servers); }},
      {"rsd_device_info_writers", "gauge", "device-info writers matched and followed.",
       [](const DomainStatus& d) { return static_cast<std::uint64_t>(d.writers); }},
      {"rsd_network_changes_total", "counter", "Times a domain was joined anew because the host's network changed.",
       [](const DomainStatus& d) { return d.network_changes; }},
  };
  for (const auto& f : per_domain_families) {
    w.family(f.name, f.type, f.help);
    for (const auto& d : in.domains) {
      if (f.value) {
        w.sample(f.name, {{"domain", std::to_string(d.domain)}}, f.value(d));
        continue;
      }
      // The one keyed by reason too: every reason the source gives is there at 0
      // from the start; others (notification-*) once counted.
      std::map<std::string, std::uint64_t> by_reason = d.rejected;
      for (const char* reason : kParseRejectReasons) by_reason.try_emplace(reason, 0);
      for (const char* reason : kBookRejectReasons) by_reason.try_emplace(reason, 0);
      for (const auto& [reason, n] : by_reason)
        w.sample(f.name, {{"domain", std::to_string(d.domain)}, {"reason", reason}}, n);
    }
  }

  w.family("rsd_writers_refused_total", "counter", "device-info writers refused by a writer cap, by reason.");
  for (const auto& d : in.domains)
    for (const char* reason : kWriterRefusedReasons) {  // 0 until it happens
      const auto n = d.writers_refused.find(reason);
      w.sample("rsd_writers_refused_total", {{"domain", std::to_string(d.domain)}, {"reason", reason}},
               n == d.writers_refused.end() ? 0 : n->second);
    }

  w.family("rsd_endpoints_refused_total", "counter",
           "readers and writers refused by an endpoint cap, or kept without their topic name, by reason.");
  for (const auto& d : in.domains)
    for (const char* reason : kEndpointRefusedReasons) {  // 0 until it happens
      const auto n = d.endpoints_refused.find(reason);
      w.sample("rsd_endpoints_refused_total", {{"domain", std::to_string(d.domain)}, {"reason", reason}},
               n == d.endpoints_refused.end() ? 0 : n->second);
    }

  if (in.usb) {
    w.family("rsd_usb_up", "gauge", "1 when local USB is watched (hotplug or polling), by state.");
    w.sample("rsd_usb_up", {{"state", in.usb->state}},
             in.usb->state == "hotplug" || in.usb->state == "polling" ? 1 : 0);
    w.family("rsd_usb_devices", "gauge", "RealSense cameras on local USB.");
    w.sample("rsd_usb_devices", {}, in.usb->devices);
  }

  w.family("rsd_device_removals_total", "counter", "Cameras removed from the table, by reason (every one from 0).");
  for (const auto r : model::kRemovalReasons)
    w.sample("rsd_device_removals_total", {{"reason", std::string(model::to_string(r))}},
             in.removals[static_cast<std::size_t>(r)]);
  w.single("rsd_device_returns_total", "counter", "Cameras listed again after they were removed.", in.returns);
  w.single("rsd_device_flaps_total", "counter",
           "Cameras lost by lease and listed again within a minute (a lossy link, a stalling server).", in.flaps);
  w.family("rsd_lease_expired_hosts_total", "counter",
           "Hosts of cameras lost by lease, probed after: still there (a hung server) or unreachable.");
  for (const auto v : model::kHostVerdicts)
    w.sample("rsd_lease_expired_hosts_total", {{"verdict", std::string(model::to_string(v))}},
             in.hosts[static_cast<std::size_t>(v)]);
  w.single("rsd_gone_devices", "gauge", "Cameras that left and are still findable as gone.", in.gone);
  w.single("rsd_history_changes", "gauge", "Presence changes the history keeps, every camera.", in.history);
  // Each expected camera at 0 or 1 from the first scrape, so an alert on 0 fires for
  // a camera that never came. "serial" is the configured key (a topic-root for a
  // camera expected by it): a series must not change labels as its camera comes and goes.
  if (in.expected.expected()) {
    w.family("rsd_expected_camera_present", "gauge", "1 when the expected camera is listed, 0 when missing.");
    for (const auto* list : {&in.expected.present, &in.expected.missing})
      for (const auto& c : *list)
        w.sample("rsd_expected_camera_present", {{"name", c.camera.name}, {"serial", c.camera.key()}},
                 list == &in.expected.present ? 1 : 0);
  }

  w.single("rsd_events_sent_total", "counter", "Device events written to SSE clients.", in.events_sent);
  w.single("rsd_event_streams", "gauge", "Open SSE streams.", in.event_streams);
  w.single("rsd_event_streams_rejected_total", "counter",
           "SSE streams refused at the limit (503).", in.event_streams_rejected);
  w.single("rsd_event_streams_dropped_total", "counter",
           "SSE streams closed because their client stopped reading (buffer limit or stall).",
           in.event_streams_dropped);
  w.single("rsd_api_connections", "gauge", "Open API connections, both listeners.", in.connections);
  w.single("rsd_api_connections_refused_total", "counter",
           "Connections answered 503 at the connection limit.", in.connections_refused);
  w.single("rsd_api_timeouts_total", "counter",
           "Connections closed for not sending a request, or not reading a response, in time.", in.timeouts);
  w.single("rsd_api_requests_rejected_total", "counter",
           "Requests refused before parsing: 414, 431, 413 or a bad Content-Length.", in.rejected);

  w.family("rsd_api_requests_total", "counter", "API requests answered, by HTTP status.");
  // The statuses the routes answer, at 0 from the start; any other once counted.
  std::map<int, std::uint64_t> by_status = in.requests_by_status;
  for (int status : kRouteStatuses) by_status.try_emplace(status, 0);
  for (const auto& [status, n] : by_status)
    w.sample("rsd_api_requests_total", {{"status", std::to_string(status)}}, n);

  if (in.process) {  // the names every Prometheus client library uses
    const ProcessStats& p = *in.process;
    w.single("process_cpu_seconds_total", "counter", "Total user and system CPU time spent in seconds.", p.cpu_seconds);
    w.single("process_resident_memory_bytes", "gauge", "Resident memory size in bytes.", p.resident_bytes);
    w.single("process_virtual_memory_bytes", "gauge", "Virtual memory size in bytes.", p.virtual_bytes);
    w.single("process_open_fds", "gauge", "Number of open file descriptors.", p.open_fds);
    w.single("process_max_fds", "gauge", "Maximum number of open file descriptors.", p.max_fds);
    w.single("process_start_time_seconds", "gauge",
             "Start time of the process since unix epoch in seconds.", p.start_time_seconds);
  }
  return w.take();
}

bool etag_matches(std::string_view header, std::string_view etag) {
  auto strip_weak = [](std::string_view t) { return t.substr(0, 2) == "W/" ? t.substr(2) : t; };
  etag = strip_weak(etag);
  while (!header.empty()) {
    const auto comma = header.find(',');
    auto item = header.substr(0, comma);
    header = comma == std::string_view::npos ? std::string_view{} : header.substr(comma + 1);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t')) item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t')) item.remove_suffix(1);
    if (item == "*" || (!item.empty() && strip_weak(item) == etag)) return true;
  }
  return false;
}

std::string list_etag(std::uint64_t generation, bool complete) {
  return "\"" + std::to_string(generation) + (complete ? "" : "-partial") + "\"";
}

}  // namespace rsd::api
