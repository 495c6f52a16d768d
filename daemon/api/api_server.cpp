#include "api/api_server.hpp"

#include "api/embedded.hpp"
#include "api/format.hpp"
#include "api/host_check.hpp"
#include "api/listener.hpp"
#include "api/process_stats.hpp"
#include "api/server_loop.hpp"
#include "rsd_model/description.hpp"
#include "log/log.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <regex>
#include <thread>

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/stat.h>
#include <unistd.h>

namespace rsd::api {

namespace {

constexpr const char* kJson = "application/json";
constexpr const char* kAllow = "GET, HEAD";
// How long stop() gives answers and streams' last chunks to go out.
constexpr std::chrono::milliseconds kStopGrace{500};
// The API takes no bodies; anything bigger than this is refused before it is read.
constexpr std::size_t kMaxPayload = 64 * 1024;

// `.+`, not `[^/]+`: a topic-root ("realsense/D455_1") names a device too, and httplib
// matches the decoded path.
const std::regex kDeviceRoute(R"(/v1/devices/(.+))");

// Camera Discovery waits on the camera: its requests go to the blocking pool,
// never onto an event loop that serves everyone else.
bool blocking_target(std::string_view target) {
  const auto path = target.substr(0, target.find('?'));
  constexpr std::string_view suffix = "/description";
  return path.size() > suffix.size() && path.substr(path.size() - suffix.size()) == suffix;
}

bool known_path(const std::string& path) {
  static const std::set<std::string> fixed = {"/",       "/openapi.yaml", "/v1/devices", "/v1/events", "/v1/domains",
                                              "/v1/participants", "/healthz", "/metrics"};
  return fixed.contains(path) || std::regex_match(path, kDeviceRoute);
}

void send_json(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(dump(body) + "\n", kJson);
}

void send_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(error_body(status, message), kJson);
}

}  // namespace

struct ApiServer::Impl {
  SharedTable& table;
  const StatusSource& status;
  const std::string version;
  ApiOptions options;

  std::unique_ptr<RequestServer> unix_server;
  std::unique_ptr<RequestServer> http_server;
  std::unique_ptr<RequestServer> offline_unix, offline_http;  // answer()
  std::unique_ptr<ServerLoop> loop;
  int unix_fd = -1;
  int http_fd = -1;
  HostCheck host_check;  // the HTTP listener's

  std::string socket_path;  // the socket file we created and must remove; "" if none
  struct stat socket_stat{};
  int bound_http_port = 0;
  model::HttpHealth http_status;  // /healthz "http", set by start()

  // Names this server in the threads' list caches (see device_list).
  const std::uint64_t instance = next_instance++;
  static inline std::atomic<std::uint64_t> next_instance{1};

  std::mutex lifecycle;
  std::atomic<bool> stopping{false};
  bool started = false;

  std::atomic<std::uint64_t> events_sent{0};
  std::atomic<std::size_t> streams_open{0};
  std::atomic<std::uint64_t> streams_rejected{0};
  // Answers by status (100-599), counted without a lock: every request touches it.
  std::array<std::atomic<std::uint64_t>, 600> requests_by_status{};

  Impl(SharedTable& t, const StatusSource& s, std::string v) : table(t), status(s), version(std::move(v)) {}

  std::vector<DomainStatus> domains() const {
    std::vector<DomainStatus> out = status.domains();
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.domain < b.domain; });
    return out;
  }

  // The table is complete once every domain has finished its first discovery:
  // before that, a device missing from it may simply not have been heard yet, so
  // the answers say so and clients wait rather than report it gone. USB needs no
  // term of its own: UsbSource::start() has listed the cameras present before it
  // returns (hotplug ENUMERATE, or the first rescan), and main.cpp starts it before
  // the API. No domains at all: nothing to wait for.
  static bool complete(const std::vector<DomainStatus>& list) {
    return std::all_of(list.begin(), list.end(), [](const DomainStatus& d) { return d.complete; });
  }

  static std::map<int, std::size_t> count_by_domain(const std::vector<nlohmann::json>& devices) {
    std::map<int, std::size_t> out;
    for (const auto& d : devices)
      if (auto it = d.find(model::key::domain); it != d.end() && it->is_number_integer()) ++out[it->get<int>()];
    return out;
  }

  void configure(RequestServer& svr, bool http);
  std::shared_ptr<const SharedBody> device_list(const DeviceFilter& filter, const std::string& query, bool done,
                                                 std::uint64_t& generation);
  void handle_devices(const httplib::Request& req, httplib::Response& res);
  void handle_device(const httplib::Request& req, httplib::Response& res);
  void handle_description(const httplib::Request& req, httplib::Response& res);
  // The devices `name` names: the one with that id, else those with that serial
  // or topic-root.
  std::vector<nlohmann::json> lookup(const std::string& name) const;
  void handle_domains(const httplib::Request& req, httplib::Response& res);
  void handle_participants(const httplib::Request& req, httplib::Response& res);
  void handle_health(const httplib::Request& req, httplib::Response& res);
  void handle_page(const httplib::Request& req, httplib::Response& res);
  void handle_spec(const httplib::Request& req, httplib::Response& res);
  void handle_metrics(const httplib::Request& req, httplib::Response& res);
  void handle_events(const httplib::Request& req, httplib::Response& res);

  void start(const ApiOptions& opts);
  void stop();
  void stop_locked();
};

void ApiServer::Impl::configure(RequestServer& svr, bool http) {
  svr.set_payload_max_length(kMaxPayload);
  // Only what httplib writes in its Keep-Alive header: the loop decides when a
  // connection ends (ServerLoop's idle timeout).
  svr.set_keep_alive_max_count(100000);
  svr.set_keep_alive_timeout(std::max(1, options.idle_timeout_ms / 1000));

  svr.Get("/v1/devices", [this](const auto& req, auto& res) { handle_devices(req, res); });
  // Before the device route, whose `.+` would take ".../description" too.
  svr.Get(R"(/v1/devices/(.+)/description)", [this](const auto& req, auto& res) { handle_description(req, res); });
  svr.Get(R"(/v1/devices/(.+))", [this](const auto& req, auto& res) { handle_device(req, res); });
  svr.Get("/v1/domains", [this](const auto& req, auto& res) { handle_domains(req, res); });
  svr.Get("/v1/participants", [this](const auto& req, auto& res) { handle_participants(req, res); });
  svr.Get("/v1/events", [this](const auto& req, auto& res) { handle_events(req, res); });
  svr.Get("/healthz", [this](const auto& req, auto& res) { handle_health(req, res); });
  svr.Get("/", [this](const auto& req, auto& res) { handle_page(req, res); });
  svr.Get("/openapi.yaml", [this](const auto& req, auto& res) { handle_spec(req, res); });
  svr.Get("/metrics", [this](const auto& req, auto& res) { handle_metrics(req, res); });

  // Any other method: 405 where the path exists (so a client learns it is
  // read-only), 404 where it does not. Registered as plain handlers so httplib
  // reads (and bounds) the body first and the connection stays in step.
  auto not_allowed = [](const httplib::Request& req, httplib::Response& res) {
    if (known_path(req.path)) {
      res.set_header("Allow", kAllow);
      send_error(res, 405, "method " + req.method + " not allowed on " + req.path + "; the API is read-only");
    } else {
      send_error(res, 404, "no such path: " + req.path);
    }
  };
  // httplib 0.11 answers 400 to a POST/PUT/PATCH/DELETE that has no body
  // headers at all (it expects one) before any route runs; with no body there is
  // nothing to read, so answer such requests here, before that check.
  svr.set_pre_routing_handler([this, http, not_allowed](const httplib::Request& req, httplib::Response& res) {
    if (http && !host_check.allows(req.get_header_value("Host"))) {
      send_error(res, 421,
                 "this daemon does not answer for host '" + req.get_header_value("Host") +
                     "'; use its address or localhost (allowed-hosts in the configuration adds names)");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.method == "GET" || req.method == "HEAD" || req.has_header("Content-Length") ||
        req.has_header("Transfer-Encoding"))
      return httplib::Server::HandlerResponse::Unhandled;
    not_allowed(req, res);
    return httplib::Server::HandlerResponse::Handled;
  });
  svr.Post(".*", not_allowed);
  svr.Put(".*", not_allowed);
  svr.Patch(".*", not_allowed);
  svr.Delete(".*", not_allowed);
  svr.Options(".*", not_allowed);

  // Whatever httplib answers on its own (no route, unparsable request, too big)
  // still gets a JSON body.
  svr.set_error_handler(httplib::Server::HandlerWithResponse([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    std::string message(status_text(res.status));
    if (res.status == 404) message = "no such path: " + req.path;
    if (res.status == 405) res.set_header("Allow", kAllow);
    res.set_content(error_body(res.status, message), kJson);
    return httplib::Server::HandlerResponse::Handled;
  }));
  svr.set_exception_handler([](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unknown error";
    try {
      if (ep) std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    log::error("api: " + req.method + " " + req.path + " failed: " + what);
    send_error(res, 500, "internal error");
  });
  svr.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
    if (res.status >= 100 && res.status < 600) ++requests_by_status[static_cast<std::size_t>(res.status)];
    if (log::enabled(log::Level::debug))
      log::debug("api: " + req.method + " " + req.target + " -> " + std::to_string(res.status));
  });
}

namespace {

// /v1/devices bodies of the table's current generation, by query, kept by each
// thread that serves requests (the event loops): a busy poller costs a lookup, not
// a snapshot and a JSON dump, and the loops never wait on each other's lock for it
// (a shared cache's mutex showed as task switches in the profile).
struct ListCache {
  std::uint64_t server = 0;  // ApiServer::Impl::instance
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

std::shared_ptr<const SharedBody> ApiServer::Impl::device_list(const DeviceFilter& filter, const std::string& query,
                                                                bool done, std::uint64_t& generation) {
  auto& cache = tls_list_cache;
  if (cache.server == instance && cache.generation == table.generation())
    for (const auto& e : cache.entries)
      if (e.complete == done && e.query == query) {
        generation = cache.generation;
        return e.body;
      }
  auto snap = table.snapshot();
  nlohmann::json devices = nlohmann::json::array();
  for (auto& d : snap.devices)
    if (filter.matches(d)) devices.push_back(std::move(d));
  // The generation lets a client list, then stream with ?since=generation,
  // without missing or repeating an event in between.
  nlohmann::json doc = {{"generation", snap.generation}, {"complete", done}, {"devices", std::move(devices)}};
  auto body = std::make_shared<const SharedBody>(dump(doc) + "\n");
  if (cache.server != instance || cache.generation != snap.generation) cache = {instance, snap.generation, {}};
  if (cache.entries.size() < 16) cache.entries.push_back({done, query, body});
  generation = snap.generation;
  return body;
}

void ApiServer::Impl::handle_devices(const httplib::Request& req, httplib::Response& res) {
  DeviceFilter filter;
  if (auto err = parse_device_filter(req.params, filter)) return send_error(res, 400, *err);
  std::string query;  // the parsed parameters in order: the cache's key
  for (const auto& [k, v] : req.params) query += k + "=" + v + "&";
  // Completeness first, then the snapshot: "complete": true then promises that the
  // list was taken after the first discovery ended, never just before.
  const bool done = status.discovery_complete();
  std::uint64_t generation = 0;
  auto body = device_list(filter, query, done, generation);
  // The table's generation names the body: a client that has it already gets a
  // 304 and keeps what it parsed.
  const std::string etag = "\"" + std::to_string(generation) + (done ? "" : "-partial") + "\"";
  res.set_header("ETag", etag);
  res.set_header("Cache-Control", "no-cache");
  if (etag_matches(req.get_header_value("If-None-Match"), etag)) {
    res.status = 304;
    return;
  }
  res.status = 200;
  // Served from the shared bytes, not copied into the response (nor, by the loop,
  // into the socket: see SharedBody).
  res.set_content_provider(body->bytes().size(), kJson,
                           [body](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             return write_shared(sink, body, offset, length);
                           });
}

std::vector<nlohmann::json> ApiServer::Impl::lookup(const std::string& name) const {
  if (auto doc = table.find(name)) return {std::move(*doc)};
  // Not an id: a serial or a topic-root names a device too (the model's rule), when it
  // names exactly one; two cameras behind one serial must be told apart by id.
  std::vector<nlohmann::json> hits;
  for (auto& d : table.snapshot().devices)
    if (model::device_from_json(d).named_by(name)) hits.push_back(std::move(d));
  return hits;
}

void ApiServer::Impl::handle_device(const httplib::Request& req, httplib::Response& res) {
  if (auto err = check_params("/v1/devices/{id}", req.params, {})) return send_error(res, 400, *err);
  const std::string id = req.matches.size() > 1 ? req.matches[1].str() : "";
  const bool done = status.discovery_complete();
  auto hits = lookup(id);
  if (hits.size() == 1) return send_json(res, 200, hits.front());
  if (hits.size() > 1) {
    nlohmann::json ids = nlohmann::json::array();
    for (const auto& d : hits) ids.push_back(d.value(model::key::id, std::string()));
    return send_json(res, 409, {{"error", std::to_string(hits.size()) + " devices match '" + id +
                                              "'; name one by its id"},
                                {"status", 409},
                                {"ids", std::move(ids)}});
  }
  // A 404 from an incomplete table may turn into a 200 in a moment: say which it
  // is, so a client can wait instead of reporting the camera absent.
  send_json(res, 404, {{"error", "no device with id '" + id + "'" +
                                     (done ? "" : " (the daemon's first discovery is not complete yet)")},
                       {"status", 404},
                       {"complete", done}});
}

void ApiServer::Impl::handle_description(const httplib::Request& req, httplib::Response& res) {
  if (auto err = check_params("/v1/devices/{id}/description", req.params, {})) return send_error(res, 400, *err);
  const std::string name = req.matches.size() > 1 ? req.matches[1].str() : "";
  const auto hits = lookup(name);
  if (hits.size() != 1)
    return send_error(res, hits.empty() ? 404 : 409,
                      hits.empty() ? "no device with id '" + name + "'"
                                   : std::to_string(hits.size()) + " devices match '" + name + "'; name one by its id");
  // Blocks this worker until the camera's server has sent its set (a few ms once
  // asked; the first time for a device) or the describe timeout.
  const auto answer = status.describe(hits.front().value("id", std::string()));
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

void ApiServer::Impl::handle_domains(const httplib::Request& req, httplib::Response& res) {
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

void ApiServer::Impl::handle_participants(const httplib::Request& req, httplib::Response& res) {
  ParticipantFilter filter;
  if (auto err = parse_participant_filter(req.params, filter)) return send_error(res, 400, *err);
  nlohmann::json list = nlohmann::json::array();
  for (const auto& p : status.participants())
    if (filter.matches(p)) list.push_back(model::to_json(p));
  send_json(res, 200, {{"participants", std::move(list)}});
}

void ApiServer::Impl::handle_page(const httplib::Request& req, httplib::Response& res) {
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

void ApiServer::Impl::handle_spec(const httplib::Request& req, httplib::Response& res) {
  if (auto err = check_params("/openapi.yaml", req.params, {})) return send_error(res, 400, *err);
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("Cache-Control", "no-cache");
  res.set_content(std::string(embedded::openapi_yaml), "application/yaml");
}

void ApiServer::Impl::handle_health(const httplib::Request& req, httplib::Response& res) {
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
  if (const auto u = status.usb()) {
    health.usb.state = u->state;
    health.usb.devices = u->devices;
    if (!u->error.empty()) health.usb.error = u->error;
  }
  send_json(res, 200, model::to_json(health));
}

void ApiServer::Impl::handle_metrics(const httplib::Request& req, httplib::Response& res) {
  if (auto err = check_params("/metrics", req.params, {})) return send_error(res, 400, *err);
  MetricsInput in;
  in.version = version;
  in.process = read_process_stats();
  in.domains = domains();
  in.usb = status.usb();
  auto snap = table.snapshot();
  in.devices_per_domain = count_by_domain(snap.devices);
  in.devices_total = snap.devices.size();
  in.generation = snap.generation;
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

namespace {

std::string resync_message(std::uint64_t generation, const std::string& reason) {
  nlohmann::json data = {{"generation", generation}, {"reason", reason}};
  return sse_message("resync", generation, dump(data));
}

// One SSE client's feed: what it has been sent up to (`cursor`), its filter, and
// when it next needs a keep-alive. The server loop owns it with the connection
// and polls it on table changes; its destructor frees the stream slot.
class TableFeed final : public EventFeed {
 public:
  TableFeed(const SharedTable& table, std::atomic<std::size_t>& open, std::atomic<std::uint64_t>& sent,
            std::chrono::milliseconds keepalive)
      : table_(table), open_(open), sent_(sent), keepalive_(keepalive) {}
  ~TableFeed() override { --open_; }

  std::uint64_t cursor = 0;  // last generation this client has been brought past
  DeviceFilter filter;
  std::string pending;  // sent first

  std::string poll(Clock::time_point now) override {
    std::string out = std::move(pending);
    pending.clear();
    if (table_.generation() != cursor) {
      const auto got = table_.wait_events(cursor, std::chrono::milliseconds(0));
      if (got.gap) {
        cursor = table_.generation();
        out += resync_message(cursor, "missed events are no longer kept; re-list /v1/devices");
      }
      std::uint64_t n = 0;
      for (const auto& e : got.events) {
        cursor = e.generation;
        // Only a filtered stream reads the device; the others send the logged bytes.
        if (!filter.empty() && !filter.matches(e.device())) continue;
        out += sse_message(to_string(e.type), e.generation, *e.document);
        ++n;
      }
      sent_ += n;
    }
    // A dead client is only noticed when a write fails; the keep-alive is also that probe.
    if (out.empty() && now >= next_keepalive_) out = sse_comment("keep-alive");
    if (!out.empty()) next_keepalive_ = now + keepalive_;
    return out;
  }

 private:
  const SharedTable& table_;
  std::atomic<std::size_t>& open_;
  std::atomic<std::uint64_t>& sent_;
  const std::chrono::milliseconds keepalive_;
  Clock::time_point next_keepalive_ = Clock::now() + keepalive_;
};

}  // namespace

void ApiServer::Impl::handle_events(const httplib::Request& req, httplib::Response& res) {
  DeviceFilter filter;
  if (auto err = parse_device_filter(req.params, filter, {"since"})) return send_error(res, 400, *err);

  std::optional<std::uint64_t> since;
  bool bad_last_event_id = false;
  if (req.has_param("since")) {
    since = parse_generation(req.get_param_value("since"));
    if (!since) return send_error(res, 400, "bad since '" + req.get_param_value("since") + "': expected a generation");
  }
  // Last-Event-ID is what EventSource sends back on its own; it wins over ?since.
  if (req.has_header("Last-Event-ID")) {
    const auto v = req.get_header_value("Last-Event-ID");
    since = parse_generation(v);
    if (!since) bad_last_event_id = true;  // not an id of ours: the client must re-list
  }

  const auto limit = options.max_event_streams;
  std::size_t n = streams_open.load();
  do {
    if (n >= limit) {
      ++streams_rejected;
      res.set_header("Retry-After", "5");
      return send_error(res, 503, "too many event streams (limit " + std::to_string(limit) + "); retry later");
    }
  } while (!streams_open.compare_exchange_weak(n, n + 1));

  auto feed = std::make_shared<TableFeed>(table, streams_open, events_sent,
                                         std::chrono::milliseconds(std::max(10, options.keepalive_ms)));
  feed->filter = std::move(filter);
  // Browsers reconnect after `retry` ms; a local daemon restarts quickly.
  feed->pending = "retry: 1000\n\n";
  if (bad_last_event_id) {
    feed->cursor = table.generation();
    feed->pending += resync_message(feed->cursor, "unknown Last-Event-ID; re-list /v1/devices");
  } else if (!since) {
    feed->cursor = table.generation();
    nlohmann::json hello = {{"generation", feed->cursor}, {"version", version}};
    feed->pending += sse_message("hello", feed->cursor, dump(hello));
  } else {
    feed->cursor = *since;  // the first poll replays from here, or tells the client to resync
  }

  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Accel-Buffering", "no");  // nginx and friends must not hold events back
  // httplib writes the headers and the first chunk; then the server loop takes the
  // connection over and feeds it on table changes (no thread waits per stream).
  res.set_chunked_content_provider("text/event-stream", [feed](std::size_t, httplib::DataSink& sink) -> bool {
    auto* context = RequestContext::current();
    const auto first = feed->poll(Clock::now());
    if (!context || !sink.write(first.data(), first.size())) return false;
    context->adopt_as_stream = feed;
    return false;  // httplib stops here and writes nothing more
  });
}

namespace {

// A request held in memory and its answer collected: the offline form of the loop's
// ConnectionStream.
class MemoryStream final : public httplib::Stream {
 public:
  explicit MemoryStream(std::string_view in) : in_(in) {}
  std::string out;
  bool is_readable() const override { return pos_ < in_.size(); }
  bool is_writable() const override { return true; }
  ssize_t read(char* ptr, size_t size) override {
    if (pos_ >= in_.size()) return -1;
    const auto n = std::min(size, in_.size() - pos_);
    std::memcpy(ptr, in_.data() + pos_, n);
    pos_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    out.append(ptr, size);
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 40000;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = "127.0.0.1";
    port = 8035;
  }
  socket_t socket() const override { return -1; }

 private:
  std::string_view in_;
  std::size_t pos_ = 0;
};

}  // namespace

void ApiServer::Impl::start(const ApiOptions& opts) {
  std::lock_guard lock(lifecycle);
  if (started) throw std::runtime_error("API server already started");
  options = opts;
  stopping = false;
  try {
    std::vector<LoopListener> listeners;
    if (opts.inherited_unix_fd >= 0 || !opts.unix_socket.empty()) {
      std::string where;
      if (opts.inherited_unix_fd >= 0) {
        unix_fd = opts.inherited_unix_fd;  // systemd owns the file; we never remove it
        where = "unix fd " + std::to_string(unix_fd);
      } else {
        unix_fd = listen_unix(opts.unix_socket);
        socket_path = opts.unix_socket;
        lstat(socket_path.c_str(), &socket_stat);
        where = "unix socket " + socket_path;
      }
      unix_server = std::make_unique<RequestServer>(unix_fd);
      configure(*unix_server, false);
      listeners.push_back({unix_fd, unix_server.get(), false, where});
    }
    if (opts.inherited_http_fd >= 0 || !opts.http_host.empty()) {
      std::string where;
      if (opts.inherited_http_fd >= 0) {
        http_fd = opts.inherited_http_fd;
        int yes = 1;
        // Accepted sockets inherit TCP_NODELAY from the listener on Linux.
        setsockopt(http_fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
        where = "http fd " + std::to_string(http_fd);
      } else {
        http_fd = listen_tcp(opts.http_host, opts.http_port);
        where = "http " + opts.http_host + ":" + std::to_string(bound_port(http_fd));
      }
      bound_http_port = bound_port(http_fd);
      host_check = HostCheck({opts.http_host, bound_address(http_fd)}, bound_to_any(http_fd), opts.allowed_hosts);
      if (!bound_to_loopback(http_fd))
        log::warning("api: HTTP listens on " + where +
                     ", beyond this machine: every host that reaches it can read the camera inventory and its "
                     "addresses (the API has no authentication); bind it to 127.0.0.1 unless that is meant");
      if (!host_check.enabled()) log::warning("api: allowed-hosts has \"*\": HTTP answers any Host header");
      http_server = std::make_unique<RequestServer>(http_fd);
      configure(*http_server, true);
      listeners.push_back({http_fd, http_server.get(), true, where});
    }
    http_status = http_health(opts.http_host, opts.http_port, opts.http_configured, http_fd >= 0 ? bound_address(http_fd) : "",
                       bound_http_port, opts.inherited_http_fd >= 0);
    // The socket unit decides under systemd; a configuration naming another address
    // was changed in one place only, and clients going by it find nothing there.
    if (!http_status.agrees)
      log::warning("api: HTTP listens on " + http_status.listening +
                   " (the socket unit's ListenStream=), but the configuration's \"http\" is " + http_status.configured +
                   ": under systemd the socket unit decides; change the address there ('systemctl edit "
                   "rs-discoveryd.socket') and make \"http\" the same, or leave it out");

    LoopOptions lo;
    lo.threads = opts.loop_threads;
    lo.blocking_threads = opts.blocking_threads;
    lo.max_connections = opts.max_connections;
    lo.client_timeout = std::chrono::milliseconds(opts.client_timeout_ms);
    lo.idle_timeout = std::chrono::milliseconds(opts.idle_timeout_ms);
    lo.stream_buffer_limit = opts.stream_buffer_limit;
    lo.blocking = blocking_target;
    // One request through each server before the loops exist: cpp-httplib makes
    // function-local statics on its first request (parse_request_line's set of
    // methods), and made here, on one thread, they are made before any loop runs
    // (which also spares ThreadSanitizer a race it cannot see the guard of).
    for (auto* server : {unix_server.get(), http_server.get()})
      if (server) {
        MemoryStream warmup("GET /healthz HTTP/1.1\r\nHost: localhost\r\n\r\n");
        bool closed = false;
        server->serve(warmup, true, closed);
      }
    loop = std::make_unique<ServerLoop>(lo);
    loop->start(listeners);
    table.set_change_hook([l = loop.get()] { l->notify_change(); });
    for (const auto& l : listeners) log::info("api: listening on " + l.name);
  } catch (...) {
    started = true;  // so that stop_locked() undoes what did start
    stop_locked();
    throw;
  }
  started = true;
}

void ApiServer::Impl::stop() {
  std::lock_guard lock(lifecycle);
  stop_locked();
}

void ApiServer::Impl::stop_locked() {
  if (!started) return;
  stopping = true;
  // No change reaches the loop once this returns (the hook is not running).
  table.set_change_hook(nullptr);
  if (loop) loop->stop(kStopGrace);
  loop.reset();
  // systemd's sockets are closed too: systemd keeps its own copy listening for
  // the next start; ours only must not outlive the server.
  for (int* fd : {&unix_fd, &http_fd})
    if (*fd >= 0) {
      ::close(*fd);
      *fd = -1;
    }
  unix_server.reset();
  http_server.reset();
  if (!socket_path.empty()) {
    // Only our own file: if another daemon replaced it meanwhile, it is theirs.
    struct stat now{};
    if (lstat(socket_path.c_str(), &now) == 0 && now.st_ino == socket_stat.st_ino && now.st_dev == socket_stat.st_dev)
      unlink(socket_path.c_str());
    socket_path.clear();
  }
  bound_http_port = 0;
  http_status = {};
  started = false;
}

ApiServer::ApiServer(SharedTable& table, const StatusSource& status, std::string version)
    : impl_(std::make_unique<Impl>(table, status, std::move(version))) {}

ApiServer::~ApiServer() { stop(); }

void ApiServer::start(const ApiOptions& options) { impl_->start(options); }

void ApiServer::stop() { impl_->stop(); }

int ApiServer::http_port() const { return impl_->bound_http_port; }

std::string ApiServer::answer(std::string_view request, bool http) {
  // Configured once per kind, as start() configures the listeners' servers; any
  // value but INVALID_SOCKET keeps httplib writing bodies (see RequestServer).
  auto& server = http ? impl_->offline_http : impl_->offline_unix;
  if (!server) {
    server = std::make_unique<RequestServer>(0);
    impl_->configure(*server, http);
  }
  MemoryStream stream(request);
  bool closed = false;
  server->serve(stream, false, closed);
  return std::move(stream.out);
}

}  // namespace rsd::api
