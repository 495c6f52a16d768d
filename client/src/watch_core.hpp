// The thread behind a Watch or a Subscription; not installed.
#pragma once

#include "internal.hpp"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

namespace rsdiscovery {

class WatchCore {
 public:
  using Sink = std::function<void(Event&&)>;
  using StatusSink = std::function<void(const WatchStatus&)>;
  using EndSink = std::function<void(std::exception_ptr)>;

  WatchCore(Endpoint endpoint, ClientOptions client_options, WatchOptions options);
  ~WatchCore();
  WatchCore(const WatchCore&) = delete;
  WatchCore& operator=(const WatchCore&) = delete;

  // Starts the thread and returns once the stream is open and the view listed;
  // throws the error of that first attempt. `on_end` runs on the thread as it ends.
  void start(Sink sink, StatusSink status, EndSink on_end);
  void start_pull();  // events go to a queue that next() reads
  void start_view();  // events only change the view (a DeviceView): nothing queued

  void stop();  // idempotent; joins, unless called from the watch's own thread
  bool finished() const;
  void wait_finished();
  std::exception_ptr end_error() const;
  std::uint64_t last_event_id() const;
  std::vector<Device> devices() const;
  bool connected() const { return connected_; }
  std::optional<Event> next(std::optional<std::chrono::milliseconds> timeout);

 private:
  void run();
  void connect_once(bool& connected);
  void handle(const detail::SseMessage& message);
  void apply(Event::Type type, Device device, std::uint64_t id, bool synthetic);
  // Lists the devices into the view (reporting the difference when `emit`); returns
  // the generation the list was taken at, when the daemon tells it.
  std::optional<std::uint64_t> relist(bool emit);
  // GET /v1/devices again until the daemon says its table is complete, or until
  // options_.complete_timeout; throws Error(cancelled) when the watch is stopped.
  // For re-lists that replace a view (after a resync), not for the first list.
  DeviceList list_complete();
  DeviceList list_once();  // GET /v1/devices once, as the watch's filter says
  void status(bool connected, const std::string& message);
  void first_result(std::exception_ptr error);

  detail::Transport stream_;  // the event stream
  detail::Transport lister_;  // re-lists, while the stream stays open
  WatchOptions options_;
  Sink sink_;
  StatusSink status_;
  EndSink on_end_;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  // The view: id -> device, its document in Device::json (compared with what arrives).
  std::map<std::string, Device> known_;
  bool view_complete_ = false;  // known_ came from a list (else from events only)
  std::optional<std::uint64_t> last_id_;
  // The generation of the last list: stream events up to it are already in the
  // view (they arrived while a re-list waited for the complete table).
  std::uint64_t listed_at_ = 0;
  std::deque<Event> queue_;  // pull mode
  std::atomic<bool> stop_{false};
  std::atomic<bool> connected_{false};  // the stream is open (as last told to status())
  bool first_done_ = false;
  std::exception_ptr first_error_;
  bool finished_ = false;
  std::exception_ptr end_error_;
  std::exception_ptr status_error_;  // thrown by the caller's status callback
  std::mutex join_mutex_;
  std::atomic<std::thread::id> thread_id_{};
  std::thread thread_;
};

struct Subscription::State {
  std::shared_ptr<WatchCore> core;
};

namespace detail {
// An ended watch's error goes to on_error, or to stderr: never nowhere.
void report_watch_end(std::exception_ptr error,
                      const std::function<void(std::exception_ptr)>& on_error);
}  // namespace detail

}  // namespace rsdiscovery
