// Watching the daemon's event stream: one thread per watch that keeps the stream
// open, resumes with Last-Event-ID after a disconnect, and re-lists when the daemon
// says it cannot fill the gap, so the caller sees every addition and removal.
#include "watch_core.hpp"

#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <charconv>
#include <cstdio>

namespace rsdiscovery {

using namespace std::chrono_literals;

WatchCore::WatchCore(Endpoint endpoint, ClientOptions client_options, WatchOptions options)
    : stream_(endpoint, client_options),
      lister_(endpoint, client_options),
      options_(std::move(options)),
      last_id_(options_.last_event_id()) {}

WatchCore::~WatchCore() { stop(); }

void WatchCore::start_pull() {
  start([this](Event&& e) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(e));
    }
    cv_.notify_all();
  }, options_.on_status(), {});
}

void WatchCore::start_view() {
  start([](Event&&) {}, options_.on_status(), {});
}

void WatchCore::start(Sink sink, StatusSink status, EndSink on_end) {
  sink_ = std::move(sink);
  status_ = std::move(status);
  on_end_ = std::move(on_end);
  thread_ = std::thread([this] { run(); });
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [this] { return first_done_; });
  if (first_error_) {
    lock.unlock();
    stop();
    std::rethrow_exception(first_error_);
  }
}

void WatchCore::stop() {
  stop_ = true;
  cv_.notify_all();
  if (std::this_thread::get_id() == thread_id_.load()) return;  // from the callback: it ends after
  std::lock_guard join_lock(join_mutex_);  // stop() may run on several threads at once
  if (!thread_.joinable()) return;
  std::unique_lock lock(mutex_);
  while (!finished_) {
    lock.unlock();
    stream_.cancel();  // repeated: a stream may be opening just now
    lister_.cancel();
    lock.lock();
    cv_.wait_for(lock, 50ms, [this] { return finished_; });
  }
  lock.unlock();
  thread_.join();
}

bool WatchCore::finished() const {
  std::lock_guard lock(mutex_);
  return finished_;
}

std::exception_ptr WatchCore::end_error() const {
  std::lock_guard lock(mutex_);
  return end_error_;
}

void WatchCore::wait_finished() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [this] { return finished_; });
}

std::uint64_t WatchCore::last_event_id() const {
  std::lock_guard lock(mutex_);
  return last_id_.value_or(0);
}

std::vector<Device> WatchCore::devices() const {
  std::lock_guard lock(mutex_);
  std::vector<Device> out;
  out.reserve(known_.size());
  for (const auto& [id, device] : known_) out.push_back(device);  // the daemon filtered the view already
  return out;
}

std::optional<Event> WatchCore::next(std::optional<std::chrono::milliseconds> timeout) {
  std::unique_lock lock(mutex_);
  auto ready = [this] { return !queue_.empty() || finished_ || stop_; };
  if (timeout)
    cv_.wait_for(lock, *timeout, ready);
  else
    cv_.wait(lock, ready);
  if (!queue_.empty()) {
    Event e = std::move(queue_.front());
    queue_.pop_front();
    return e;
  }
  if (finished_ && end_error_ && !stop_) std::rethrow_exception(end_error_);
  return std::nullopt;
}

void WatchCore::status(bool connected, const std::string& message) {
  connected_ = connected;
  if (!status_) return;
  try {
    status_(WatchStatus{connected, message});
  } catch (...) {  // ends the watch like a throwing event callback, never silently
    status_error_ = std::current_exception();
    stop_ = true;
  }
}

void WatchCore::first_result(std::exception_ptr error) {
  std::lock_guard lock(mutex_);
  if (first_done_) return;
  first_done_ = true;
  first_error_ = error;
  cv_.notify_all();
}

void WatchCore::run() {
  thread_id_ = std::this_thread::get_id();
  // A write to a daemon that just went away must fail with EPIPE, not kill the process.
  sigset_t pipe;
  sigemptyset(&pipe);
  sigaddset(&pipe, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe, nullptr);
  auto delay = std::chrono::milliseconds(100);
  std::exception_ptr error;
  while (!stop_) {
    bool connected = false;
    try {
      connect_once(connected);
      if (stop_) break;
      if (!options_.reconnect())
        throw Error(ErrorCode::not_running, "rs-discoveryd at " + stream_.endpoint().to_string() +
                                                " ended the event stream");
      status(false, "the event stream ended; reconnecting");
    } catch (const Error& e) {
      if (stop_ || e.code() == ErrorCode::cancelled) break;
      if (!first_done_) {  // start() hands this one to its caller
        first_result(std::current_exception());
        break;
      }
      bool transient = e.code() == ErrorCode::not_running || e.code() == ErrorCode::timeout ||
                       (e.code() == ErrorCode::http_error && e.http_status() >= 500);
      if (!transient || !options_.reconnect()) {
        error = std::current_exception();
        break;
      }
      status(false, e.what());
    } catch (...) {  // the caller's callback threw, or something unexpected
      if (!first_done_) {
        first_result(std::current_exception());
        break;
      }
      error = std::current_exception();
      break;
    }
    if (connected) delay = 100ms;
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, delay, [this] { return stop_.load(); });
    delay = std::min(delay * 2, std::max(options_.max_reconnect_delay(), 100ms));
  }
  if (!error && status_error_) error = status_error_;
  if (!first_done_ && error) {
    first_result(error);
    error = nullptr;
  }
  first_result(nullptr);
  {
    std::lock_guard lock(mutex_);
    end_error_ = error;
    finished_ = true;
    connected_ = false;
  }
  cv_.notify_all();
  if (on_end_) on_end_(error);
}

void WatchCore::connect_once(bool& connected) {
  std::exception_ptr inner;  // thrown inside the stream's callbacks, rethrown here
  detail::SseParser parser([this](detail::SseMessage&& m) { handle(m); });
  std::string last;
  bool list_on_open = false;
  {
    std::lock_guard lock(mutex_);
    if (last_id_) last = std::to_string(*last_id_);
  }
  if (last.empty()) {
    // No point to resume from: take the table as it is now, and stream from the
    // generation the list was taken at, so nothing in between is missed.
    auto generation = relist(view_complete_ || options_.initial());
    if (generation) {
      last = std::to_string(*generation);
    } else {
      list_on_open = true;  // a daemon whose list has no generation: list once the stream is open
    }
  }
  std::string path = "/v1/events";
  if (auto q = detail::devices_path(options_.filter()).find('?'); q != std::string::npos)
    path += detail::devices_path(options_.filter()).substr(q);
  stream_.stream(
      path, last,
      [&] {
        try {
          connected = true;
          status(true, "connected to " + stream_.endpoint().to_string());
          if (list_on_open) relist(view_complete_ || options_.initial());
          first_result(nullptr);
          return !stop_;
        } catch (...) {
          inner = std::current_exception();
          return false;
        }
      },
      [&](const char* data, std::size_t len) {
        try {
          parser.feed(std::string_view(data, len));
          return !stop_;
        } catch (...) {
          inner = std::current_exception();
          return false;
        }
      },
      options_.idle_timeout());
  if (inner) std::rethrow_exception(inner);
}

namespace {
std::optional<std::uint64_t> parse_id(const std::string& text) {
  std::uint64_t v = 0;
  auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || p != text.data() + text.size()) return std::nullopt;
  return v;
}
}  // namespace

void WatchCore::handle(const detail::SseMessage& m) {
  std::optional<std::uint64_t> id = m.has_id ? parse_id(m.id) : std::nullopt;
  if (m.event == "resync") {
    {
      std::lock_guard lock(mutex_);
      last_id_ = id;  // none: the next reconnect re-lists
    }
    relist(true);
    return;
  }
  if (m.event == "hello") {  // where a fresh stream starts
    if (id) {
      std::lock_guard lock(mutex_);
      last_id_ = id;
    }
    return;
  }
  Event::Type type;
  if (m.event == "added")
    type = Event::Type::added;
  else if (m.event == "changed")
    type = Event::Type::changed;
  else if (m.event == "removed")
    type = Event::Type::removed;
  else
    return;  // an event type of a later API version
  detail::DeviceDocument doc;
  if (detail::read_device(m.data, doc))
    throw Error(ErrorCode::malformed_reply, "malformed event from rs-discoveryd at " +
                                                stream_.endpoint().to_string() + ": '" + m.event +
                                                "' without a device document");
  doc.device.json = m.data;
  if (id) {
    std::lock_guard lock(mutex_);
    // Already in the view: the list that followed a resync was taken after it.
    // Applying it again could only add back a camera that has since gone.
    if (*id <= listed_at_) return;
    last_id_ = id;
  }
  apply(type, std::move(doc.device), id.value_or(0), false);
}

void WatchCore::apply(Event::Type type, Device device, std::uint64_t id, bool synthetic) {
  Event out;
  out.id = id;
  out.synthetic = synthetic;
  {
    std::lock_guard lock(mutex_);
    auto it = known_.find(device.id);
    if (type == Event::Type::removed) {
      if (it == known_.end()) {
        if (view_complete_) return;  // removed before we listed it: never seen
      } else {
        known_.erase(it);
      }
      out.type = Event::Type::removed;
      out.device = std::move(device);
    } else {
      if (it != known_.end() && detail::same_device(it->second.json, device.json)) {
        // A replay, or in the list already: nothing to report, but its times may be newer.
        it->second = std::move(device);
        return;
      }
      out.type = it == known_.end() ? Event::Type::added : Event::Type::changed;
      out.device = device;
      known_[device.id] = std::move(device);
    }
  }
  sink_(std::move(out));
}

DeviceList WatchCore::list_once() {
  const std::string path = detail::devices_path(options_.filter());
  detail::Reply reply = lister_.get(path);
  if (reply.status != 200) throw lister_.status_error(path, reply);
  DeviceList list;
  if (auto problem = detail::read_device_list(reply.body, path, list))
    throw Error(ErrorCode::malformed_reply,
                "malformed reply from rs-discoveryd at " + lister_.endpoint().to_string() + ": " + *problem);
  return list;
}

DeviceList WatchCore::list_complete() {
  const auto deadline =
      std::chrono::steady_clock::now() + std::max(options_.complete_timeout(), std::chrono::milliseconds::zero());
  for (;;) {
    DeviceList list = list_once();
    // A daemon that has just (re)started answers at once, from a table that lacks
    // the cameras it has not heard from yet: compared with the view, that list would
    // report them removed, then added again a moment later. Only a complete list
    // tells real differences.
    if (list.complete || std::chrono::steady_clock::now() >= deadline) return list;
    std::unique_lock lock(mutex_);
    const auto left = deadline - std::chrono::steady_clock::now();
    cv_.wait_for(lock, std::min<std::chrono::steady_clock::duration>(left, 50ms), [this] { return stop_.load(); });
    if (stop_) throw Error(ErrorCode::cancelled, "the watch was stopped");
  }
}

std::optional<std::uint64_t> WatchCore::relist(bool emit) {
  bool compare = false;
  {
    std::lock_guard lock(mutex_);
    compare = view_complete_;
  }
  // Only a list compared with a view it replaces needs the complete table. The first
  // list is the starting point: what the daemon has now, with every later addition
  // still to come as an event; waiting there would fold cameras that arrive meanwhile
  // into the starting point, unreported.
  DeviceList list = compare ? list_complete() : list_once();
  // 0: a daemon whose list has no generation (older than it).
  const auto generation = list.generation ? std::optional(list.generation) : std::nullopt;
  std::map<std::string, Device> fresh;  // the whole list read before the view changes
  for (auto& d : list.devices) {
    std::string id = d.id;
    fresh[std::move(id)] = std::move(d);
  }
  std::uint64_t at;
  std::vector<Device> gone;
  {
    std::lock_guard lock(mutex_);
    if (generation) {
      last_id_ = std::max(last_id_.value_or(0), *generation);
      listed_at_ = *generation;
    }
    at = last_id_.value_or(0);
    if (!emit) {
      known_ = std::move(fresh);
      view_complete_ = true;
      return generation;
    }
    for (const auto& [key, device] : known_)
      if (!fresh.count(key)) gone.push_back(device);
    view_complete_ = true;
  }
  for (auto& device : gone) apply(Event::Type::removed, std::move(device), at, true);
  for (auto& [key, device] : fresh) apply(Event::Type::added, std::move(device), at, true);
  return generation;
}

// ---- Watch ---------------------------------------------------------------------------

Watch::Watch(std::shared_ptr<WatchCore> core) : core_(std::move(core)) {}
Watch::Watch(Watch&&) noexcept = default;
Watch& Watch::operator=(Watch&&) noexcept = default;
Watch::~Watch() {
  if (core_) core_->stop();
}
std::optional<Event> Watch::next(std::chrono::milliseconds timeout) { return core_->next(timeout); }
std::optional<Event> Watch::next() { return core_->next(std::nullopt); }
void Watch::stop() { core_->stop(); }
bool Watch::stopped() const { return core_->finished(); }
std::uint64_t Watch::last_event_id() const { return core_->last_event_id(); }
std::vector<Device> Watch::devices() const { return core_->devices(); }

// ---- DeviceView ----------------------------------------------------------------------

DeviceView::DeviceView(std::shared_ptr<WatchCore> core) : core_(std::move(core)) {}
DeviceView::DeviceView(DeviceView&&) noexcept = default;
DeviceView& DeviceView::operator=(DeviceView&&) noexcept = default;
DeviceView::~DeviceView() {
  if (core_) core_->stop();
}
std::vector<Device> DeviceView::devices() const {
  // A view that no longer follows the table must not pass for one that does.
  if (core_->finished()) {
    if (auto e = core_->end_error()) std::rethrow_exception(e);
    throw Error(ErrorCode::cancelled, "the device view was stopped");
  }
  return core_->devices();
}
bool DeviceView::connected() const { return core_->connected(); }
std::uint64_t DeviceView::last_event_id() const { return core_->last_event_id(); }
void DeviceView::stop() { core_->stop(); }

// ---- Subscription --------------------------------------------------------------------

Subscription::Subscription(std::unique_ptr<State> state) : state_(std::move(state)) {}
Subscription::Subscription(Subscription&&) noexcept = default;
Subscription& Subscription::operator=(Subscription&&) noexcept = default;
Subscription::~Subscription() {
  if (state_) state_->core->stop();
}
void Subscription::stop() { state_->core->stop(); }
bool Subscription::running() const { return !state_->core->finished(); }
void Subscription::wait() {
  state_->core->wait_finished();
  if (auto e = state_->core->end_error()) std::rethrow_exception(e);
}
std::uint64_t Subscription::last_event_id() const { return state_->core->last_event_id(); }

namespace detail {

void report_watch_end(std::exception_ptr error, const std::function<void(std::exception_ptr)>& on_error) {
  if (!error) return;
  if (on_error) {
    try {
      on_error(error);
      return;
    } catch (const std::exception& e) {
      std::fprintf(stderr, "rsdiscovery: the watch's error handler threw: %s\n", e.what());
    } catch (...) {
      std::fprintf(stderr, "rsdiscovery: the watch's error handler threw\n");
    }
  }
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rsdiscovery: watch stopped: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "rsdiscovery: watch stopped by an exception that is not std::exception\n");
  }
}

}  // namespace detail
}  // namespace rsdiscovery
