// The library's insides, shared by its files and its unit tests; not installed.
#pragma once

#include "rsdiscovery/rsdiscovery.hpp"

#include "json.hpp"

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rsdiscovery::detail {

// ---- JSON -> public types --------------------------------------------------------
// Each throws Error(malformed_reply) for a document that is not what the API says.
// `text`: the document as the daemon sent it, kept as the type's json; empty: written
// anew from `doc`.

// One device document as the library reads it: the Device, and what the public
// Device has no field for (a shared camera's host, a camera's clients), each read
// whole or not at all. Device::json is left to the caller.
struct DeviceDocument {
  Device device;
  std::optional<SharingHost> host;
  std::optional<DeviceInUse> in_use;
};
enum class Unread { not_json, not_an_object, no_id };  // no_id: the rest is read
const char* to_string(Unread why);  // said for a user
std::optional<Unread> read_device(std::string_view text, DeviceDocument& out);
// A device document read, with `text` as its json; throws Error(malformed_reply)
// when it is not one.
Device device_from_text(std::string text);
// GET `path`'s reply (a /v1/devices document) into `out`: each device with its text
// as sent. A problem with the document is returned, said as for a user; a device
// without an id throws Error(malformed_reply).
std::optional<std::string> read_device_list(const std::string& body, const std::string& path, DeviceList& out);
Description description_from_json(const json::Value& doc, std::string text = {});
DomainStatus domain_from_json(const json::Value& doc);
Health health_from_json(const json::Value& doc);
Expected expected_from_json(const json::Value& doc);
Participant participant_from_json(const json::Value& doc);
CameraClients clients_from_json(const json::Value& doc);

// The text of each element of the array that member `key` of the JSON object
// `text` holds, as it stands in `text`; nothing when there is no such array.
// This only finds where things are: on text that is not JSON it still ends, with
// slices that mean nothing (Client::list takes them only when the parser accepts
// the text and finds as many devices).
std::vector<std::string_view> array_member_elements(std::string_view text, std::string_view key);

// The same device document, apart from fields that move without being news
// ("last-seen"; "first-seen", which a restarted daemon sets anew for a camera that
// never went away): what the watch compares to tell a real change.
bool same_device(std::string_view a, std::string_view b);  // two documents' texts

// Whether a /v1/devices, /healthz, /v1/domains or 404 document says the daemon's
// first discovery is over. A document without "complete" (a daemon older than the
// field) counts as complete: there is nothing to wait for.
bool reports_complete(const json::Value& doc);

// "/v1/devices?domain=7&product-line=D400" (values percent-encoded).
std::string devices_path(const DeviceFilter& filter);
// `path` (devices_path's) asking for only these keys of each device (?fields=).
std::string with_fields(std::string path, const std::vector<std::string>& fields);
std::string percent_encode(std::string_view text);

// What is read from the daemon at most, so that an endpoint that is not the daemon (or
// a broken one) cannot make a client allocate without bound: a whole reply, and one
// event of the stream (a line, or the data of one event). The daemon's largest answers
// are far below: 1,000 devices list in about 0.5 MB, a device event is about 1 KB.
constexpr std::size_t kMaxReply = std::size_t{64} << 20;
constexpr std::size_t kMaxEvent = std::size_t{16} << 20;

// ---- Server-Sent Events ------------------------------------------------------------
struct SseMessage {
  std::string event;  // "message" when the stream named none
  std::string data;   // data lines joined with '\n'
  std::string id;     // the id field of this message, "" when it had none
  bool has_id = false;
};

// Incremental parser (WHATWG rules): feed any chunking of the stream, get messages.
class SseParser {
 public:
  using Sink = std::function<void(SseMessage&&)>;
  explicit SseParser(Sink sink) : sink_(std::move(sink)) {}
  void feed(std::string_view chunk);
  std::size_t comments() const { return comments_; }  // keep-alives seen

 private:
  void line(std::string_view text);
  [[noreturn]] static void too_large();  // beyond kMaxEvent: Error(malformed_reply)
  Sink sink_;
  std::string pending_;  // an incomplete line
  bool last_was_cr_ = false;
  bool bom_checked_ = false;
  std::string event_, data_, id_;
  bool has_data_ = false, has_id_ = false;
  std::size_t comments_ = 0;
};

// ---- Transport: one HTTP connection to the daemon -----------------------------------
struct Reply {
  int status = 0;
  std::string content_type;
  std::string retry_after;  // a 503's Retry-After, in seconds
  std::string etag;         // names the body (/v1/devices: the table's generation)
  std::string body;
};

class Transport {
 public:
  Transport(Endpoint endpoint, ClientOptions options);
  ~Transport();
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  // One GET; throws Error for anything but an HTTP reply (not running, permission
  // denied, timeout). `timeout`: how long the answer may take, when not the usual
  // request timeout (a description the daemon fetches first may take 30 s).
  Reply get(const std::string& path, std::optional<std::chrono::milliseconds> timeout = std::nullopt,
            const std::string& if_none_match = "");
  // One GET, not asked again after a 503 (get() asks again as Retry-After says).
  Reply get_once(const std::string& path, std::optional<std::chrono::milliseconds> timeout,
                 const std::string& if_none_match);
  // GET and parse a JSON object (status 200), mapping 404/405 on an API path to
  // version_mismatch and other statuses to http_error.
  json::Document get_json(const std::string& path);

  // An SSE stream. `on_open` runs once the reply's head is in (return false to
  // cancel), `on_data` for each chunk (false cancels). Returns when the stream ends.
  // Throws Error for connection failures and a non-200 reply.
  void stream(const std::string& path, const std::string& last_event_id,
              const std::function<bool()>& on_open,
              const std::function<bool(const char*, std::size_t)>& on_data,
              std::chrono::milliseconds idle_timeout);
  // Ends a stream() or get() in progress on another thread (and any later one).
  void cancel();

  const Endpoint& endpoint() const { return endpoint_; }

  // The Error a non-200 reply stands for (404/405 on an API path: version mismatch).
  Error status_error(const std::string& path, const Reply& reply);

 private:
  struct Connection;
  [[noreturn]] void fail(int io_end, std::chrono::milliseconds timeout) const;
  void drop_kept();

  Endpoint endpoint_;
  ClientOptions options_;
  std::mutex mutex_;  // guards kept_ and streaming_ against cancel() from another thread
  std::unique_ptr<Connection> kept_;        // kept alive between get()s
  std::shared_ptr<Connection> streaming_;   // the stream's, for cancel()
  std::atomic<bool> cancelled_{false};
};

// Why connecting to the endpoint fails, found by trying once with a plain socket:
// an Error naming the path and what to do.
Error diagnose_connect(const Endpoint& endpoint);

}  // namespace rsdiscovery::detail
