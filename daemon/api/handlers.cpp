// The API's handlers for everything but the event stream (events.cpp): the device
// list and lookups, Camera Discovery, the domains, participants, health, metrics,
// the page and the spec.
#include "api/handlers.hpp"

#include "api/embedded.hpp"
#include "api/history_format.hpp"
#include "api/process_stats.hpp"
#include "rsd_model/description.hpp"
#include "table/expected.hpp"

#include <algorithm>

namespace rsd::api {

void send_json(ApiResponse& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(dump(body) + "\n", kJson);
}

void send_error(ApiResponse& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(error_body(status, message), kJson);
}

namespace {

// The table is complete once every domain has finished its first discovery:
// before that, a device missing from it may simply not have been heard yet, so
// the answers say so and clients wait rather than report it gone. USB needs no
// term of its own: UsbSource::start() has listed the cameras present before it
// returns (hotplug ENUMERATE, or the first rescan), and main.cpp starts it before
// the API. No domains at all: nothing to wait for.
bool complete(const std::vector<DomainStatus>& list) {
  return std::all_of(list.begin(), list.end(), [](const DomainStatus& d) { return d.complete; });
}

// A 404 for a camera key, in the words the clients use ("no device 'X'"), and where the
// keys are: an id, a serial or a topic-root, as the list gives them.
std::string no_device(const std::string& key) {
  return "no device '" + key + "' (no camera listed has it as its id, serial or topic-root; GET /v1/devices lists them)";
}

std::map<int, std::size_t> count_by_domain(const std::vector<EntryPtr>& devices) {
  std::map<int, std::size_t> out;
  for (const auto& e : devices)
    if (e->device.domain) ++out[*e->device.domain];
  return out;
}

}  // namespace

std::vector<DomainStatus> Handlers::domains() const {
  std::vector<DomainStatus> out = status.domains();
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.domain < b.domain; });
  return out;
}

namespace {

// /v1/devices bodies of the table's current generation, by query, kept by each
// thread that serves requests (the event loops): a busy poller costs a lookup, not
// a snapshot and a JSON dump, and the loops never wait on each other's lock for it
// (a shared cache's mutex showed as task switches in the profile).
struct ListCache {
  std::uint64_t server = 0;  // Handlers::instance
  std::uint64_t generation = 0;
  struct Entry {
    bool complete = false;
    std::string query;
    std::shared_ptr<const SharedBody> body;
  };
  std::vector<Entry> entries;  // a handful of distinct filters is all pollers use
};
thread_local ListCache tls_list_cache;

}  // namespace

std::shared_ptr<const SharedBody> Handlers::device_list(const DeviceFilter& filter, const DeviceFields& fields,
                                                        const std::string& query, bool done,
                                                        std::uint64_t& generation) {
  auto& cache = tls_list_cache;
  if (cache.server == instance && cache.generation == table.generation())
    for (const auto& e : cache.entries)
      if (e.complete == done && e.query == query) {
        generation = cache.generation;
        return e.body;
      }
  const auto snap = table.snapshot();
  // The generation lets a client list, then stream with ?since=generation,
  // without missing or repeating an event in between. Spelled as dump() spells
  // {"generation", "complete", "devices"} (keys sorted), from the entries' own text.
  std::string text = done ? R"({"complete":true,"devices":[)" : R"({"complete":false,"devices":[)";
  std::size_t size = text.size() + 40;
  for (const auto& e : snap.devices) size += e->text.size() + 1;
  text.reserve(size);
  bool first = true;
  for (const auto& e : snap.devices)
    if (filter.matches(e->device)) {
      if (!first) text += ',';
      // ?fields=: made here once per generation and query, as the whole list is.
      text += fields.whole() ? e->text : project_device(e->text, fields);
      first = false;
    }
  text += R"(],"generation":)" + std::to_string(snap.generation) + "}\n";
  auto body = std::make_shared<const SharedBody>(std::move(text));
  if (cache.server != instance || cache.generation != snap.generation) cache = {instance, snap.generation, {}};
  if (cache.entries.size() < 16) cache.entries.push_back({done, query, body});
  generation = snap.generation;
  return body;
}

void Handlers::handle_devices(const ApiRequest& req, ApiResponse& res) {
  DeviceFilter filter;
  if (auto err = parse_device_filter(req.params, filter, {"fields"})) return send_error(res, 400, *err);
  DeviceFields fields;
  if (auto err = parse_device_fields(req.params, fields)) return send_error(res, 400, *err);
  std::string query;  // the parsed parameters in order: the cache's key
  for (const auto& [k, v] : req.params) query += k + "=" + v + "&";
  // Completeness first, then the snapshot: "complete": true then promises that the
  // list was taken after the first discovery ended, never just before.
  const bool done = status.discovery_complete();
  std::uint64_t generation = 0;
  auto body = device_list(filter, fields, query, done, generation);
  // The table's generation names the body: a client that has it already gets a
  // 304 and keeps what it parsed.
  const std::string etag = list_etag(generation, done);
  res.set_header("ETag", etag);
  res.set_header("Cache-Control", "no-cache");
  if (etag_matches(req.header("If-None-Match"), etag)) {
    res.status = 304;
    return;
  }
  res.status = 200;
  // Served from the shared bytes, not copied into the response (nor, by the loop,
  // into the socket: see SharedBody).
  res.content_type = kJson;
  res.shared = std::move(body);
}

std::vector<EntryPtr> Handlers::lookup(const std::string& name) const {
  if (auto entry = table.find_entry(name)) return {std::move(entry)};
  // Not an id: a serial or a topic-root names a device too (the model's rule), when it
  // names exactly one; two cameras behind one serial must be told apart by id.
  std::vector<EntryPtr> hits;
  for (auto& e : table.snapshot().devices)
    if (e->device.named_by(name)) hits.push_back(std::move(e));
  return hits;
}

void Handlers::handle_device(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/v1/devices/{id}", req.params, {})) return send_error(res, 400, *err);
  const std::string& id = req.id;
  const bool done = status.discovery_complete();
  auto hits = lookup(id);
  if (hits.size() == 1) {
    res.status = 200;
    return res.set_content(hits.front()->text + "\n", kJson);
  }
  if (hits.size() > 1) {
    nlohmann::json ids = nlohmann::json::array();
    for (const auto& e : hits) ids.push_back(e->device.id);
    return send_json(res, 409, {{"error", std::to_string(hits.size()) + " devices match '" + id +
                                              "'; name one by its id"},
                                {"status", 409},
                                {"ids", std::move(ids)}});
  }
  // A camera that was here and left is not one never seen: 410, with when and why.
  if (const auto gone = table.find_gone(id))
    return send_json(res, 410, {{"error", "device '" + id + "' is gone (" + std::string(model::to_string(gone->reason)) +
                                              ", " + gone->removed_at + ")"},
                                {"status", 410},
                                {model::key::gone, gone_json(*gone)}});
  // A 404 from an incomplete table may turn into a 200 in a moment: say which it
  // is, so a client can wait instead of reporting the camera absent.
  send_json(res, 404, {{"error", no_device(id) +
                                     (done ? "" : " (the daemon's first discovery is not complete yet)")},
                       {"status", 404},
                       {"complete", done}});
}

void Handlers::handle_description(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/v1/devices/{id}/description", req.params, {})) return send_error(res, 400, *err);
  const std::string& name = req.id;
  const auto hits = lookup(name);
  if (hits.size() != 1)
    return send_error(res, hits.empty() ? 404 : 409,
                      hits.empty() ? no_device(name)
                                   : std::to_string(hits.size()) + " devices match '" + name + "'; name one by its id");
  // Blocks this worker until the camera's server has sent its set (a few ms once
  // asked; the first time for a device) or the describe timeout.
  const auto answer = status.describe(hits.front()->device.id);
  using Outcome = DeviceDescription::Outcome;
  switch (answer.outcome) {
    case Outcome::ok:
      // Through the model: what is served is exactly what the clients' type reads
      // (a drift would be a 500 here and a failing test, never a silent change).
      return send_json(res, 200, model::to_json(model::description_from_json(answer.description)));
    case Outcome::not_found:
    case Outcome::not_network:
      return send_error(res, 404, answer.error);
    case Outcome::recovery:
      return send_error(res, 409, answer.error);
    case Outcome::timeout:
      return send_error(res, 504, answer.error);
    case Outcome::unavailable:
      res.set_header("Retry-After", "2");
      return send_error(res, 503, answer.error);
  }
}

void Handlers::handle_clients(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/v1/devices/{id}/clients", req.params, {})) return send_error(res, 400, *err);
  const auto hits = lookup(req.id);
  if (hits.size() != 1)
    return send_error(res, hits.empty() ? 404 : 409,
                      hits.empty() ? "no device with id '" + req.id + "'"
                                   : std::to_string(hits.size()) + " devices match '" + req.id + "'; name one by its id");
  const model::Device& d = hits.front()->device;
  std::optional<model::DeviceClients> clients;
  if (d.domain && d.topic_root) clients = status.clients(*d.domain, *d.topic_root);
  if (!clients)
    return send_error(res, 404,
                      "'" + d.id + "' is not a network camera: the daemon cannot see who holds a USB camera "
                      "(`rs-discover clients` looks for the processes)");
  send_json(res, 200, model::to_json(*clients));
}

void Handlers::handle_domains(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/v1/domains", req.params, {})) return send_error(res, 400, *err);
  const auto all = domains();
  const auto counts = count_by_domain(table.snapshot().devices);
  nlohmann::json list = nlohmann::json::array();
  for (auto d : all) {
    auto it = counts.find(d.domain);
    d.devices = it == counts.end() ? 0 : it->second;  // the table is the truth the other routes show
    list.push_back(domain_status_json(d));
  }
  send_json(res, 200, {{"complete", complete(all)}, {"domains", std::move(list)}});
}

void Handlers::handle_participants(const ApiRequest& req, ApiResponse& res) {
  ParticipantFilter filter;
  if (auto err = parse_participant_filter(req.params, filter)) return send_error(res, 400, *err);
  nlohmann::json list = nlohmann::json::array();
  for (const auto& p : status.participants())
    if (filter.matches(p)) list.push_back(model::to_json(p));
  send_json(res, 200, {{"participants", std::move(list)}});
}

void Handlers::handle_page(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/", req.params, {})) return send_error(res, 400, *err);
  // The page runs its own inline script and style and talks to this origin only;
  // nothing else may load into it, and no other site may frame it.
  res.set_header("Content-Security-Policy",
                 "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; connect-src 'self'; "
                 "frame-ancestors 'none'; base-uri 'none'; form-action 'none'");
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("Referrer-Policy", "no-referrer");
  res.set_header("Cache-Control", "no-cache");
  res.set_content(std::string(embedded::web_page), "text/html; charset=utf-8");
}

void Handlers::handle_spec(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/openapi.yaml", req.params, {})) return send_error(res, 400, *err);
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("Cache-Control", "no-cache");
  res.set_content(std::string(embedded::openapi_yaml), "application/yaml");
}

void Handlers::handle_health(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/healthz", req.params, {})) return send_error(res, 400, *err);
  model::Health health;
  health.version = version;
  health.complete = status.discovery_complete();
  {
    const auto snap = table.snapshot();
    health.devices = snap.devices.size();
    health.generation = snap.generation;
  }
  health.http = http_status;
  if (auto expected = status.expected(); !expected.empty())
    health.expected = expected_report(expected, table, health.complete);
  if (const auto u = status.usb()) {
    health.usb.state = u->state;
    health.usb.devices = u->devices;
    if (!u->error.empty()) health.usb.error = u->error;
  }
  send_json(res, 200, model::to_json(health));
}

void Handlers::handle_expected(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/v1/expected", req.params, {})) return send_error(res, 400, *err);
  // Completeness first, as for the list: "complete": true promises the table was read after.
  const bool done = status.discovery_complete();
  send_json(res, 200, model::to_json(expected_report(status.expected(), table, done)));
}

void Handlers::handle_metrics(const ApiRequest& req, ApiResponse& res) {
  if (auto err = check_params("/metrics", req.params, {})) return send_error(res, 400, *err);
  MetricsInput in;
  in.version = version;
  in.process = read_process_stats();
  in.domains = domains();
  in.usb = status.usb();
  auto snap = table.snapshot();
  in.expected = expected_report(status.expected(), snap.devices, status.discovery_complete());
  in.devices_per_domain = count_by_domain(snap.devices);
  in.devices_total = snap.devices.size();
  in.generation = snap.generation;
  const TableCounts counts = table.counts();
  in.removals = counts.removals;
  in.returns = counts.returns;
  in.flaps = counts.flaps;
  in.hosts = counts.hosts;
  in.gone = counts.gone;
  in.history = counts.history;
  in.events_sent = events_sent.load();
  in.event_streams = streams_open.load();
  in.event_streams_rejected = streams_rejected.load();
  if (loop) {
    const auto ls = loop->stats();
    in.event_streams_dropped = ls.streams_dropped;
    in.connections = ls.connections;
    in.connections_refused = ls.refused;
    in.timeouts = ls.timed_out;
    in.rejected = ls.rejected;
  }
  for (std::size_t code = 100; code < requests_by_status.size(); ++code)
    if (const auto n = requests_by_status[code].load()) in.requests_by_status[static_cast<int>(code)] = n;
  res.status = 200;
  res.set_content(render_metrics(in), "text/plain; version=0.0.4; charset=utf-8");
}

}  // namespace rsd::api
