#include "api/api_server.hpp"

#include "api/format.hpp"
#include "api/listener.hpp"
#include "log/log.hpp"

#include <algorithm>
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
// How long an SSE worker waits on the table before it looks at the stop flag
// again; bounds how long stop() waits for streams.
constexpr std::chrono::milliseconds kStreamSlice{100};
// The API takes no bodies; anything bigger than this is refused before it is read.
constexpr std::size_t kMaxPayload = 64 * 1024;

// `.+`, not `[^/]+`: a topic-root ("realsense/D455_1") names a device too, and httplib
// matches the decoded path.
const std::regex kDeviceRoute(R"(/v1/devices/(.+))");

bool known_path(const std::string& path) {
  static const std::set<std::string> fixed = {"/v1/devices", "/v1/events", "/v1/domains", "/healthz",
                                              "/metrics"};
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

  struct Slot {
    std::unique_ptr<Listener> server;
    std::thread thread;
    SocketAddress address;
    std::string name;  // for logs
  };
  std::vector<Slot> slots;

  std::string socket_path;  // the socket file we created and must remove; "" if none
  struct stat socket_stat{};
  int bound_http_port = 0;

  std::mutex lifecycle;
  std::atomic<bool> stopping{false};
  bool started = false;

  std::atomic<std::uint64_t> events_sent{0};
  std::atomic<std::size_t> streams_open{0};
  std::atomic<std::uint64_t> streams_rejected{0};
  std::mutex requests_mutex;
  std::map<int, std::uint64_t> requests_by_status;

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

  void configure(Listener& svr);
  void handle_devices(const httplib::Request& req, httplib::Response& res);
  void handle_device(const httplib::Request& req, httplib::Response& res);
  void handle_description(const httplib::Request& req, httplib::Response& res);
  // The devices `name` names: the one with that id, else those with that serial
  // or topic-root.
  std::vector<nlohmann::json> lookup(const std::string& name) const;
  void handle_domains(const httplib::Request& req, httplib::Response& res);
  void handle_health(const httplib::Request& req, httplib::Response& res);
  void handle_metrics(const httplib::Request& req, httplib::Response& res);
  void handle_events(const httplib::Request& req, httplib::Response& res);

  void launch(std::unique_ptr<Listener> server, std::string name, bool adopted);
  void start(const ApiOptions& opts);
  void stop();
  void stop_locked();
};

void ApiServer::Impl::configure(Listener& svr) {
  const auto threads = static_cast<std::size_t>(std::max(4, options.worker_threads));
  svr.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  svr.set_tcp_nodelay(true);
  // httplib's default options set SO_REUSEPORT, which would let a second daemon
  // bind the same port and silently share it; SO_REUSEADDR alone still allows a
  // quick restart while refusing a port someone is listening on.
  svr.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  svr.set_payload_max_length(kMaxPayload);
  // httplib's default of 5 requests per connection makes polling clients reconnect needlessly.
  svr.set_keep_alive_max_count(1000);
  svr.set_read_timeout(5, 0);
  svr.set_write_timeout(5, 0);

  svr.Get("/v1/devices", [this](const auto& req, auto& res) { handle_devices(req, res); });
  // Before the device route, whose `.+` would take ".../description" too.
  svr.Get(R"(/v1/devices/(.+)/description)", [this](const auto& req, auto& res) { handle_description(req, res); });
  svr.Get(R"(/v1/devices/(.+))", [this](const auto& req, auto& res) { handle_device(req, res); });
  svr.Get("/v1/domains", [this](const auto& req, auto& res) { handle_domains(req, res); });
  svr.Get("/v1/events", [this](const auto& req, auto& res) { handle_events(req, res); });
  svr.Get("/healthz", [this](const auto& req, auto& res) { handle_health(req, res); });
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
  svr.set_pre_routing_handler([not_allowed](const httplib::Request& req, httplib::Response& res) {
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
    {
      std::lock_guard lock(requests_mutex);
      ++requests_by_status[res.status];
    }
    if (log::enabled(log::Level::debug))
      log::debug("api: " + req.method + " " + req.target + " -> " + std::to_string(res.status));
  });
}

void ApiServer::Impl::handle_devices(const httplib::Request& req, httplib::Response& res) {
  DeviceFilter filter;
  if (auto err = parse_device_filter(req.params, filter)) return send_error(res, 400, *err);
  // Completeness first, then the snapshot: "complete": true then promises that the
  // list was taken after the first discovery ended, never just before.
  const bool done = complete(domains());
  auto snap = table.snapshot();
  nlohmann::json devices = nlohmann::json::array();
  for (auto& d : snap.devices)
    if (filter.matches(d)) devices.push_back(std::move(d));
  // The generation lets a client list, then stream with ?since=generation,
  // without missing or repeating an event in between.
  send_json(res, 200, {{"generation", snap.generation}, {"complete", done}, {"devices", std::move(devices)}});
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
  const bool done = complete(domains());
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
      return send_json(res, 200, answer.description);
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

void ApiServer::Impl::handle_health(const httplib::Request& req, httplib::Response& res) {
  if (auto err = check_params("/healthz", req.params, {})) return send_error(res, 400, *err);
  const bool done = complete(domains());
  auto snap = table.snapshot();
  nlohmann::json usb = {{"state", "off"}};
  if (const auto u = status.usb()) {
    usb = {{"state", u->state}, {"devices", u->devices}};
    if (!u->error.empty()) usb["error"] = u->error;
  }
  send_json(res, 200,
            {{"status", "ok"},
             {"version", version},
             {"devices", snap.devices.size()},
             {"generation", snap.generation},
             // "ok" says the daemon works; this says whether its device count is
             // final yet (false for the first seconds after a start).
             {"complete", done},
             {"usb", std::move(usb)}});
}

void ApiServer::Impl::handle_metrics(const httplib::Request& req, httplib::Response& res) {
  if (auto err = check_params("/metrics", req.params, {})) return send_error(res, 400, *err);
  MetricsInput in;
  in.version = version;
  in.domains = domains();
  in.usb = status.usb();
  auto snap = table.snapshot();
  in.devices_per_domain = count_by_domain(snap.devices);
  in.devices_total = snap.devices.size();
  in.generation = snap.generation;
  in.events_sent = events_sent.load();
  in.event_streams = streams_open.load();
  in.event_streams_rejected = streams_rejected.load();
  {
    std::lock_guard lock(requests_mutex);
    in.requests_by_status = requests_by_status;
  }
  res.status = 200;
  res.set_content(render_metrics(in), "text/plain; version=0.0.4; charset=utf-8");
}

namespace {

// One SSE client's state, shared by the content provider's copies; its
// destructor frees the stream slot however the stream ends.
struct Stream {
  std::atomic<std::size_t>* open = nullptr;
  std::uint64_t cursor = 0;  // last generation this client has been brought past
  DeviceFilter filter;
  std::string pending;  // written on the first provider call
  std::chrono::steady_clock::time_point next_keepalive;
  ~Stream() {
    if (open) --*open;
  }
};

std::string resync_message(std::uint64_t generation, const std::string& reason) {
  nlohmann::json data = {{"generation", generation}, {"reason", reason}};
  return sse_message("resync", generation, dump(data));
}

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

  const auto limit = static_cast<std::size_t>(std::max(0, options.max_event_streams));
  std::size_t n = streams_open.load();
  do {
    if (n >= limit) {
      ++streams_rejected;
      res.set_header("Retry-After", "5");
      return send_error(res, 503, "too many event streams (limit " + std::to_string(limit) + "); retry later");
    }
  } while (!streams_open.compare_exchange_weak(n, n + 1));

  auto st = std::make_shared<Stream>();
  st->open = &streams_open;
  st->filter = std::move(filter);
  // Browsers reconnect after `retry` ms; a local daemon restarts quickly.
  st->pending = "retry: 1000\n\n";
  if (bad_last_event_id) {
    st->cursor = table.generation();
    st->pending += resync_message(st->cursor, "unknown Last-Event-ID; re-list /v1/devices");
  } else if (!since) {
    st->cursor = table.generation();
    nlohmann::json hello = {{"generation", st->cursor}, {"version", version}};
    st->pending += sse_message("hello", st->cursor, dump(hello));
  } else {
    st->cursor = *since;  // the provider replays from here, or tells the client to resync
  }
  st->next_keepalive = std::chrono::steady_clock::now() + std::chrono::milliseconds(options.keepalive_ms);

  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Accel-Buffering", "no");  // nginx and friends must not hold events back
  const auto keepalive = std::chrono::milliseconds(std::max(10, options.keepalive_ms));
  res.set_chunked_content_provider(
      "text/event-stream", [this, st, keepalive](std::size_t, httplib::DataSink& sink) -> bool {
        // httplib does not catch here; an escaping exception would end the process.
        try {
          auto write = [&](const std::string& s) { return sink.write(s.data(), s.size()); };
          if (stopping || table.closed()) {
            sink.done();
            return true;
          }
          if (!st->pending.empty()) {
            std::string out = std::move(st->pending);
            st->pending.clear();
            if (!write(out)) return false;
          }
          const auto now = std::chrono::steady_clock::now();
          const auto until_keepalive =
              std::chrono::duration_cast<std::chrono::milliseconds>(st->next_keepalive - now);
          const auto wait = std::clamp(until_keepalive, std::chrono::milliseconds(0), kStreamSlice);
          auto got = table.wait_events(st->cursor, wait);
          if (stopping) {
            sink.done();
            return true;
          }
          std::string out;
          std::uint64_t sent = 0;
          if (got.gap) {
            st->cursor = table.generation();
            out = resync_message(st->cursor, "missed events are no longer kept; re-list /v1/devices");
          }
          for (const auto& e : got.events) {
            st->cursor = e.generation;
            if (!st->filter.matches(e.device)) continue;
            out += sse_message(to_string(e.type), e.generation, dump(e.device));
            ++sent;
          }
          if (!out.empty()) {
            if (!write(out)) return false;
            events_sent += sent;
            st->next_keepalive = std::chrono::steady_clock::now() + keepalive;
          } else if (std::chrono::steady_clock::now() >= st->next_keepalive) {
            // A dead client is only noticed when a write fails; this is also that probe.
            if (!write(sse_comment("keep-alive"))) return false;
            st->next_keepalive = std::chrono::steady_clock::now() + keepalive;
          }
          return true;
        } catch (const std::exception& e) {
          log::error(std::string("api: event stream failed: ") + e.what());
          return false;
        }
      });
}

void ApiServer::Impl::launch(std::unique_ptr<Listener> server, std::string name, bool adopted) {
  Slot slot;
  slot.address = local_address(server->fd());
  slot.name = std::move(name);
  Listener* raw = server.get();
  slot.server = std::move(server);
  slot.thread = std::thread([raw, n = slot.name] {
    if (!raw->listen_after_bind()) log::error("api: listener on " + n + " ended with an error");
  });
  // stop() is a no-op on a server that is not running yet; wait, so a stop()
  // right after start() cannot be lost. The socket already listens (bind_to_port
  // does listen(2)), so clients connecting meanwhile just queue.
  // httplib listens with a backlog of 5, which a burst of local clients overflows
  // (a Unix-socket connect then fails with EAGAIN); calling listen(2) again only
  // raises it. Not for inherited sockets: their backlog is systemd's setting.
  if (!adopted) ::listen(raw->fd(), SOMAXCONN);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!raw->is_running() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const bool running = raw->is_running();
  slots.push_back(std::move(slot));  // stop_locked() joins its thread either way
  if (!running) throw std::runtime_error("API listener on " + slots.back().name + " failed to start");
}

void ApiServer::Impl::start(const ApiOptions& opts) {
  std::lock_guard lock(lifecycle);
  if (started) throw std::runtime_error("API server already started");
  options = opts;
  stopping = false;
  try {
    if (opts.inherited_unix_fd >= 0 || !opts.unix_socket.empty()) {
      auto svr = std::make_unique<Listener>();
      configure(*svr);
      svr->set_address_family(AF_UNIX);
      std::string where;
      if (opts.inherited_unix_fd >= 0) {
        svr->adopt(opts.inherited_unix_fd);  // systemd owns the file; we never remove it
        where = "unix fd " + std::to_string(opts.inherited_unix_fd);
      } else {
        prepare_unix_socket_path(opts.unix_socket);
        // Created 0660 from the start (umask), not chmod-ed after a window in which
        // anyone could connect; chmod then fixes group write if the umask was stricter.
        const mode_t old = umask(0117);
        const bool ok = svr->bind_to_port(opts.unix_socket, 1);  // the port is ignored for AF_UNIX
        const int err = errno;
        umask(old);
        if (!ok)
          throw std::runtime_error("cannot listen on unix socket '" + opts.unix_socket + "': " + std::strerror(err));
        socket_path = opts.unix_socket;
        lstat(socket_path.c_str(), &socket_stat);
        chmod(socket_path.c_str(), 0660);
        where = "unix socket " + socket_path;
      }
      launch(std::move(svr), where, opts.inherited_unix_fd >= 0);
      log::info("api: listening on " + where);
    }

    if (opts.inherited_http_fd >= 0 || !opts.http_host.empty()) {
      auto svr = std::make_unique<Listener>();
      configure(*svr);
      std::string where;
      if (opts.inherited_http_fd >= 0) {
        int yes = 1;
        // Accepted sockets inherit TCP_NODELAY from the listener on Linux.
        setsockopt(opts.inherited_http_fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
        svr->adopt(opts.inherited_http_fd);
        where = "http fd " + std::to_string(opts.inherited_http_fd);
      } else {
        std::string host = opts.http_host;
        if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
        errno = 0;
        bool ok;
        if (opts.http_port == 0) {
          ok = svr->bind_to_any_port(host) > 0;
        } else {
          ok = svr->bind_to_port(host, opts.http_port);
        }
        const int err = errno;
        if (!ok)
          throw std::runtime_error("cannot listen on http " + opts.http_host + ":" + std::to_string(opts.http_port) +
                                   ": " + (err ? std::strerror(err) : "address not usable"));
        where = "http " + opts.http_host + ":" + std::to_string(opts.http_port);
      }
      const auto addr = local_address(svr->fd());
      if (addr.storage.ss_family == AF_INET)
        bound_http_port = ntohs(reinterpret_cast<const sockaddr_in&>(addr.storage).sin_port);
      else if (addr.storage.ss_family == AF_INET6)
        bound_http_port = ntohs(reinterpret_cast<const sockaddr_in6&>(addr.storage).sin6_port);
      if (opts.http_port == 0 && opts.inherited_http_fd < 0)
        where = "http " + opts.http_host + ":" + std::to_string(bound_http_port);
      launch(std::move(svr), where, opts.inherited_http_fd >= 0);
      log::info("api: listening on " + where);
    }
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
  stopping = true;  // SSE providers see it within kStreamSlice and end their streams
  for (auto& s : slots) s.server->halt();  // inherited sockets stay systemd's, listening
  // Give streams the moment they need to end cleanly (a final empty chunk, so
  // clients see an orderly end rather than a reset); the shutdown below
  // would cut them anyway.
  const auto drain_until = std::chrono::steady_clock::now() + 2 * kStreamSlice;
  while (streams_open.load() > 0 && std::chrono::steady_clock::now() < drain_until)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  // With the listeners closed no new connection arrives; wake the workers that
  // sit on idle keep-alive connections or slow clients.
  for (auto& s : slots) shutdown_accepted_connections(s.address);
  for (auto& s : slots)
    if (s.thread.joinable()) s.thread.join();
  slots.clear();
  if (!socket_path.empty()) {
    // Only our own file: if another daemon replaced it meanwhile, it is theirs.
    struct stat now{};
    if (lstat(socket_path.c_str(), &now) == 0 && now.st_ino == socket_stat.st_ino && now.st_dev == socket_stat.st_dev)
      unlink(socket_path.c_str());
    socket_path.clear();
  }
  bound_http_port = 0;
  started = false;
}

ApiServer::ApiServer(SharedTable& table, const StatusSource& status, std::string version)
    : impl_(std::make_unique<Impl>(table, status, std::move(version))) {}

ApiServer::~ApiServer() { stop(); }

void ApiServer::start(const ApiOptions& options) { impl_->start(options); }

void ApiServer::stop() { impl_->stop(); }

int ApiServer::http_port() const { return impl_->bound_http_port; }

}  // namespace rsd::api
