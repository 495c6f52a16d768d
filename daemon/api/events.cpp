// The event stream, GET /v1/events: one TableFeed per client, which the server loop
// polls on every table change and on keep-alive deadlines.
#include "api/handlers.hpp"
#include "api/history_format.hpp"

#include <algorithm>

namespace rsd::api {

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
        // A filter reads the entry's typed fields; every stream sends the logged bytes
        // (with the reason of a removal, or the arrival of an addition).
        // A change that takes a device out of the filter (a renumbered server no
        // longer at ?address=) is its removal for this client, one that brings it in
        // its arrival: else a filtered watcher kept a device it would never list.
        EventType type = e.type;
        if (!filter.empty()) {
          const bool after = filter.matches(e.entry->device);
          const bool before = e.type == EventType::changed && e.previous ? filter.matches(e.previous->device) : after;
          if (!before && !after) continue;
          if (before != after) type = after ? EventType::added : EventType::removed;
        }
        out += sse_message(to_string(type), e.generation, event_document(e, type));
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

void Handlers::handle_events(const ApiRequest& req, ApiResponse& res) {
  DeviceFilter filter;
  if (auto err = parse_device_filter(req.params, filter, {"since"})) return send_error(res, 400, *err);

  std::optional<std::uint64_t> since;
  bool bad_last_event_id = false;
  if (req.has_param("since")) {
    since = parse_generation(req.param("since"));
    if (!since) return send_error(res, 400, "bad since '" + req.param("since") + "': expected a generation");
  }
  // Last-Event-ID is what EventSource sends back on its own; it wins over ?since.
  if (req.has_header("Last-Event-ID")) {
    const auto v = req.header("Last-Event-ID");
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
  // The seam writes the headers and the first chunk; then the server loop takes the
  // connection over and feeds it on table changes (no thread waits per stream).
  res.content_type = "text/event-stream";
  res.stream = std::move(feed);
}

}  // namespace rsd::api
