// The client: one kept-alive connection for requests, one thread per watch.
#include "watch_core.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <thread>

namespace rsdiscovery {

using Clock = std::chrono::steady_clock;

namespace {
// How often an answer from an incomplete table is asked again. The first discovery
// ends a few seconds after the daemon starts, at no moment a client can know, and a
// request on the kept-alive connection costs well under a millisecond.
constexpr std::chrono::milliseconds kCompletePoll{50};

void pause_until(Clock::time_point deadline) {
  auto left = deadline - Clock::now();
  if (left > Clock::duration::zero()) std::this_thread::sleep_for(std::min<Clock::duration>(left, kCompletePoll));
}
}  // namespace

struct Client::Impl {
  Impl(Endpoint ep, ClientOptions opts) : endpoint(std::move(ep)), options(opts), transport(endpoint, opts) {}
  Endpoint endpoint;
  ClientOptions options;
  std::mutex mutex;  // one request at a time on the connection
  detail::Transport transport;

  json::Document get_json(const std::string& path) {
    std::lock_guard lock(mutex);
    return transport.get_json(path);
  }

  // The moment until which an answer from an incomplete table is asked again.
  Clock::time_point complete_deadline() const {
    return Clock::now() + std::max(options.complete_timeout(), std::chrono::milliseconds::zero());
  }

  // GET `path` again until the answer says the table is complete, or `deadline`.
  json::Document get_complete_json(const std::string& path, Clock::time_point deadline) {
    for (;;) {
      json::Document reply = get_json(path);
      if (detail::reports_complete(reply) || Clock::now() >= deadline) return reply;
      pause_until(deadline);
    }
  }

  DeviceList list(const DeviceFilter& filter, Clock::time_point deadline, const std::vector<std::string>& fields = {});
  std::optional<Device> find_device(const std::string& id, std::string* gone);
  // The daemon answered 400 to ?fields= (older than it): whole documents from then on.
  bool fields_refused = false;  // under `mutex`

  // The last list of each path and its ETag: asked again with If-None-Match, an
  // unchanged table is a 304 and this copy, not a parse of every document again
  // (a poller's list then costs about the round trip).
  struct CachedList {
    std::string etag;
    DeviceList list;
    bool asked = false;  // this filter was listed before
  };
  std::map<std::string, CachedList> lists;  // under `mutex`
};

Client::Client() : Client(Endpoint::from_environment()) {}
Client::Client(Endpoint endpoint, ClientOptions options)
    : impl_(std::make_unique<Impl>(std::move(endpoint), options)) {}
Client::Client(const std::string& endpoint, ClientOptions options)
    : Client(endpoint.empty() ? Endpoint::from_environment() : Endpoint::parse(endpoint), options) {}
Client::Client(Client&&) noexcept = default;
Client& Client::operator=(Client&&) noexcept = default;
Client::~Client() = default;

const Endpoint& Client::endpoint() const { return impl_->endpoint; }

namespace {
[[noreturn]] void malformed(const Endpoint& ep, const std::string& what) {
  throw Error(ErrorCode::malformed_reply,
              "malformed reply from rs-discoveryd at " + ep.to_string() + ": " + what);
}
}  // namespace

DeviceList Client::Impl::list(const DeviceFilter& filter, Clock::time_point deadline,
                              const std::vector<std::string>& fields) {
  const std::string whole = detail::devices_path(filter);
  std::string projected;
  if (!fields.empty()) projected = detail::with_fields(whole, fields);
  for (;;) {
    std::unique_lock lock(mutex);
    const std::string& path = projected.empty() || fields_refused ? whole : projected;
    auto& cached = lists[path];
    detail::Reply reply = transport.get(path, std::nullopt, cached.etag);
    if (reply.status == 304 && !cached.etag.empty()) {
      if (cached.list.complete || Clock::now() >= deadline) return cached.list;
    } else {
      if (reply.status == 400 && &path == &projected) {  // a daemon without ?fields=
        fields_refused = true;
        continue;
      }
      if (reply.status != 200) throw transport.status_error(path, reply);
      DeviceList out;
      if (auto problem = detail::read_device_list(reply.body, path, out)) malformed(endpoint, *problem);
      // Kept for an If-None-Match from the second list of this filter on: a one-shot
      // caller (the CLI) does not pay for a copy of every device it never asks again.
      if (cached.asked) cached = {reply.etag, out, true};
      cached.asked = true;
      if (out.complete || Clock::now() >= deadline) return out;
    }
    lock.unlock();
    pause_until(deadline);  // an incomplete table: ask again until it is complete
  }
}

DeviceList Client::list(const DeviceFilter& filter) { return impl_->list(filter, impl_->complete_deadline()); }

DeviceList Client::list(const DeviceFilter& filter, const std::vector<std::string>& fields) {
  return impl_->list(filter, impl_->complete_deadline(), fields);
}

// GET /v1/devices/{id}: nothing when absent. A camera that was here and left (410)
// is absent too, so a program polling for one keeps its "nothing"; `gone`, when
// given, gets the daemon's sentence saying why and since when.
std::optional<Device> Client::Impl::find_device(const std::string& id, std::string* gone) {
  std::string path = "/v1/devices/" + detail::percent_encode(id);
  const auto deadline = complete_deadline();
  detail::Reply reply;
  for (;;) {
    {
      std::lock_guard lock(mutex);
      reply = transport.get(path);
    }
    if (reply.status != 404) break;
    // Absent from an incomplete table: it may be a camera not heard from yet.
    const auto body = json::parse_or_null(reply.body);
    if (!body.IsObject() || detail::reports_complete(body) || Clock::now() >= deadline) return std::nullopt;
    pause_until(deadline);
  }
  if (reply.status == 409) {  // a serial or topic-root of several devices: the daemon lists their ids
    const auto body = json::parse_or_null(reply.body);
    std::string message =
        json::text_or(json::find(body, "error"), "'" + id + "' names several devices; name one by its id");
    for (const auto& other : json::texts(json::find(body, "ids"))) message += "\n  " + other;
    throw Error(ErrorCode::not_found, message, 409);
  }
  if (reply.status == 410) {
    if (gone) {
      *gone = json::text_or(json::find(json::parse_or_null(reply.body), "error"), "device '" + id + "' is gone");
    }
    return std::nullopt;
  }
  if (reply.status != 200) {
    std::lock_guard lock(mutex);
    transport.get_json(path);  // turns the status into its Error
    malformed(endpoint, "GET " + path + " answered " + std::to_string(reply.status));
  }
  detail::DeviceDocument doc;
  if (const auto why = detail::read_device(reply.body, doc))
    malformed(endpoint, "GET " + path +
                            (*why == detail::Unread::not_json ? " is not JSON" : std::string(": ") + to_string(*why)));
  doc.device.json = std::move(reply.body);
  return std::move(doc.device);
}

std::vector<Device> Client::list_devices(const DeviceFilter& filter) { return list(filter).devices; }

std::optional<Device> Client::find_device(const std::string& id) { return impl_->find_device(id, nullptr); }

Device Client::get_device(const std::string& id) {
  std::string gone;
  if (auto d = impl_->find_device(id, &gone)) return *d;
  if (!gone.empty()) throw Error(ErrorCode::not_found, gone, 410);
  throw Error(ErrorCode::not_found, "no device '" + id + "' at rs-discoveryd (" +
                                        impl_->endpoint.to_string() + ")",
              404);
}

Description Client::describe(const std::string& id, std::chrono::milliseconds timeout) {
  const std::string path = "/v1/devices/" + detail::percent_encode(id) + "/description";
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    detail::Reply reply;
    {
      std::lock_guard lock(impl_->mutex);
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      reply = impl_->transport.get(path, std::max(left, std::chrono::milliseconds(1)));
    }
    json::Document body;
    const bool not_json = json::parse(reply.body, body).has_value();
    if (reply.status == 200) {
      if (not_json) malformed(impl_->endpoint, "GET " + path + " is not JSON");
      return detail::description_from_json(body, std::move(reply.body));
    }
    const std::string message = json::text_or(json::find(body, "error"));
    if (reply.status == 404)
      throw Error(ErrorCode::not_found,
                  message.empty() ? "no device '" + id + "' at rs-discoveryd (" + impl_->endpoint.to_string() + ")"
                                  : message,
                  404);
    if (reply.status == 503 && !reply.retry_after.empty()) {
      // The daemon is making its DDS participant anew: ask again when it says.
      int seconds = 1;
      try {
        seconds = std::clamp(std::stoi(reply.retry_after), 1, 30);
      } catch (const std::exception&) {
      }
      const auto again = Clock::now() + std::chrono::seconds(seconds);
      if (again < deadline) {
        if (impl_->options.on_busy())
          impl_->options.on_busy()("rs-discoveryd at " + impl_->endpoint.to_string() + " cannot describe '" + id +
                                 "' yet: " + (message.empty() ? "HTTP 503" : message) + "; asking again in " +
                                 std::to_string(seconds) + " s");
        std::this_thread::sleep_until(again);
        continue;
      }
    }
    if (reply.status == 409 || reply.status == 503 || reply.status == 504)
      throw Error(ErrorCode::http_error,
                  "rs-discoveryd at " + impl_->endpoint.to_string() + " cannot describe '" + id + "': " +
                      (message.empty() ? "HTTP " + std::to_string(reply.status) : message),
                  reply.status);
    std::lock_guard lock(impl_->mutex);
    throw impl_->transport.status_error(path, reply);
  }
}

std::vector<DomainStatus> Client::domains() {
  const auto reply = impl_->get_json("/v1/domains");
  const auto* list = json::find(reply, "domains");
  if (!list || !list->IsArray()) malformed(impl_->endpoint, "no \"domains\" array");
  std::vector<DomainStatus> out;
  for (const auto& d : list->GetArray()) out.push_back(detail::domain_from_json(d));
  return out;
}

CameraClients Client::clients(const std::string& id) {
  const std::string path = "/v1/devices/" + detail::percent_encode(id) + "/clients";
  detail::Reply reply;
  {
    std::lock_guard lock(impl_->mutex);
    reply = impl_->transport.get(path);
  }
  json::Document body;
  const bool not_json = json::parse(reply.body, body).has_value();
  // A 404 with the daemon's error is about the camera (none, or a USB one); one
  // without is an older daemon, which get_json says.
  if (const auto error = json::text(json::find(body, "error")); reply.status == 404 && error)
    throw Error(ErrorCode::not_found, std::string(*error), 404);
  if (reply.status != 200 || not_json) return detail::clients_from_json(impl_->get_json(path));
  return detail::clients_from_json(body);
}

std::vector<Participant> Client::participants(std::optional<int> domain) {
  const auto reply =
      impl_->get_json(domain ? "/v1/participants?domain=" + std::to_string(*domain) : "/v1/participants");
  const auto* list = json::find(reply, "participants");
  if (!list || !list->IsArray()) malformed(impl_->endpoint, "no \"participants\" array");
  std::vector<Participant> out;
  for (const auto& p : list->GetArray()) out.push_back(detail::participant_from_json(p));
  return out;
}

std::string Client::device_history(const std::string& id) {
  const std::string path = "/v1/devices/" + detail::percent_encode(id) + "/history";
  std::lock_guard lock(impl_->mutex);
  auto reply = impl_->transport.get(path);
  if (reply.status == 404)
    throw Error(ErrorCode::not_found, "no device '" + id + "' was ever seen by rs-discoveryd (" +
                                          impl_->endpoint.to_string() + ")",
                404);
  if (reply.status != 200) impl_->transport.get_json(path);  // throws its Error
  return reply.body;
}

std::string Client::history(std::uint64_t since) {
  const std::string path = "/v1/history?since=" + std::to_string(since);
  std::lock_guard lock(impl_->mutex);
  auto reply = impl_->transport.get(path);
  if (reply.status != 200) impl_->transport.get_json(path);  // throws its Error
  return reply.body;
}

Health Client::health() { return detail::health_from_json(impl_->get_json("/healthz")); }

Expected Client::expected() { return detail::expected_from_json(impl_->get_json("/v1/expected")); }

std::string Client::metrics() {
  std::lock_guard lock(impl_->mutex);
  auto reply = impl_->transport.get("/metrics");
  if (reply.status != 200) impl_->transport.get_json("/metrics");  // throws its Error
  return reply.body;
}

Watch Client::watch(WatchOptions options) {
  auto core = std::make_shared<WatchCore>(impl_->endpoint, impl_->options, std::move(options));
  core->start_pull();
  return Watch(std::move(core));
}

DeviceView Client::view(WatchOptions options) {
  options.initial(false);  // nothing to report: the view is what is kept
  auto core = std::make_shared<WatchCore>(impl_->endpoint, impl_->options, std::move(options));
  core->start_view();
  return DeviceView(std::move(core));
}

Subscription Client::watch(std::function<void(const Event&)> on_event, WatchOptions options,
                           std::function<void(std::exception_ptr)> on_error,
                           std::function<void(const WatchStatus&)> on_status) {
  auto core = std::make_shared<WatchCore>(impl_->endpoint, impl_->options, std::move(options));
  auto state = std::make_unique<Subscription::State>();
  state->core = core;
  core->start([cb = std::move(on_event)](Event&& e) { cb(e); }, std::move(on_status),
              [on_error = std::move(on_error)](std::exception_ptr e) {
                detail::report_watch_end(e, on_error);
              });
  return Subscription(std::move(state));
}

std::optional<std::vector<Device>> Client::wait_until(
    const DeviceFilter& filter, const std::function<bool(const std::vector<Device>&)>& predicate,
    std::chrono::milliseconds timeout) {
  auto deadline = std::chrono::steady_clock::now() + timeout;
  // The predicate is only asked about the complete table (a set condition such as
  // "no camera" or "at least two" would hold by mistake on a partial one), as far
  // as both waits allow.
  const auto complete_by = std::min(deadline, impl_->complete_deadline());
  // Fast path: it may hold already, and one request is much cheaper than a watch.
  if (auto now = impl_->list(filter, complete_by).devices; predicate(now)) return now;
  WatchOptions options;
  options.filter(filter).complete_timeout(
      std::max(std::chrono::duration_cast<std::chrono::milliseconds>(complete_by - Clock::now()),
               std::chrono::milliseconds::zero()));
  Watch w = watch(options);
  for (;;) {
    auto devices = w.devices();
    if (predicate(devices)) return devices;
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left <= std::chrono::milliseconds::zero()) return std::nullopt;
    w.next(left);  // any event (or the timeout): look again
  }
}

std::optional<Device> Client::wait_for(const std::function<bool(const Device&)>& predicate,
                                       std::chrono::milliseconds timeout) {
  std::optional<Device> found;
  auto set = wait_until({}, [&](const std::vector<Device>& devices) {
    for (const auto& d : devices)
      if (predicate(d)) {
        found = d;
        return true;
      }
    return false;
  }, timeout);
  return set ? found : std::nullopt;
}

}  // namespace rsdiscovery
