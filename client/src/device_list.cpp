// A device document and GET /v1/devices' reply read into the public types, straight
// from the parse's events (json::Events): no tree is built, and each value is copied
// once, into the field that keeps it. The rules are the daemon's reader's (proto/model
// device.cpp), for what the public Device holds: a value of another type than the
// key's is not taken, and an object the daemon owns ("server", "usb", "host",
// "in-use") is taken whole or not at all. tests/unit holds the two readers to the same
// answers, and fuzz_client_documents to every input.
#include "internal.hpp"

#include "device_keys.hpp"

#include <cstdint>
#include <limits>
#include <span>
#include <utility>

namespace rsdiscovery::detail {

namespace {

using namespace device_keys;

// The members an object the daemon owns must have, each counted as often as it comes.
int required_of(Slot part) {
  switch (part) {
    case Slot::usb: return 6;  // bus, address, port-path, speed, vid, pid
    case Slot::host: return 2;  // name, addresses
    case Slot::in_use: return 2;  // clients, streaming
    default: return 0;
  }
}

// A value that is not an object or an array.
struct Scalar {
  enum class Kind : std::uint8_t { null, boolean, negative, whole, number, string } kind = Kind::null;
  bool b = false;
  std::int64_t i = 0;  // negative
  std::uint64_t u = 0;  // whole
  std::string_view s = {};

  bool is_number() const { return kind == Kind::negative || kind == Kind::whole || kind == Kind::number; }
  // A whole number within an int, as the fields that hold one take it.
  std::optional<int> as_int() const {
    if (kind == Kind::negative && i >= std::numeric_limits<int>::min()) return static_cast<int>(i);
    if (kind == Kind::whole && u <= static_cast<std::uint64_t>(std::numeric_limits<int>::max()))
      return static_cast<int>(u);
    return std::nullopt;
  }
};

// The list's or the device's reading, as the parse tells it. Each object or array
// the reader is in is a frame; `skipped` is one whose values nothing reads.
class DocumentReader final : public json::Events {
 public:
  enum class Kind : std::uint8_t { list, devices, device, part, strings, skipped };
  // What is wrong with the first device that is wrong, in the list's order.
  enum class DeviceProblem : std::uint8_t { none, not_an_object, no_id };

  // list: the text is GET /v1/devices' reply, read into `list`; else one device
  // document, read into `single`.
  DocumentReader(DeviceList* list, DeviceDocument* single) : list_(list), single_(single) { frames_.reserve(8); }

  bool top_is_object() const { return top_is_object_; }
  bool has_devices() const { return has_devices_; }
  DeviceProblem device_problem() const { return device_problem_; }
  // Where each listed device stood in the text (json::Events' `at`, each end).
  const std::vector<std::pair<std::size_t, std::size_t>>& spans() const { return spans_; }

  void null() override { scalar({.kind = Scalar::Kind::null}); }
  void boolean(bool b) override { scalar({.kind = Scalar::Kind::boolean, .b = b}); }
  void integer(std::int64_t i) override { scalar({.kind = Scalar::Kind::negative, .i = i}); }
  void unsigned_integer(std::uint64_t u) override { scalar({.kind = Scalar::Kind::whole, .u = u}); }
  void number(double) override { scalar({.kind = Scalar::Kind::number}); }
  void string(std::string_view s) override { scalar({.kind = Scalar::Kind::string, .s = s}); }
  void key(std::string_view k) override;
  void start_object(std::size_t at) override { open(true, at); }
  void end_object(std::size_t at, std::size_t) override { close(at); }
  void start_array() override { open(false, 0); }
  void end_array(std::size_t) override { close(0); }

 private:
  struct Frame {
    Kind kind;
    Slot slot = Slot::ignored;  // an object's: what the value of its last key is for; a part's or strings': whose
    bool ok = true;  // a part: nothing refused so far; strings: each element a string (a source for "sources")
    int counted = 0;  // a part: its required members so far
    std::uint8_t next_key = 0;  // an object: where slot_of looks first
    std::size_t at = 0;  // a device: where it starts
  };

  Device& device() { return list_ ? list_->devices.back() : single_->device; }
  void scalar(const Scalar& v);
  void open(bool object, std::size_t at);
  void close(std::size_t at);
  void take(Frame& f, const Scalar& v);
  void take_part(Frame& f, const Scalar& v);
  void strings_end(const Frame& strings);
  void part_end(const Frame& part);
  void device_end(const Frame& device, std::size_t at);
  void device_wrong(DeviceProblem p) {
    if (device_problem_ == DeviceProblem::none) device_problem_ = p;
  }

  DeviceList* const list_;
  DeviceDocument* const single_;
  std::vector<Frame> frames_;
  bool top_is_object_ = false;
  // The list's first "devices", "generation" and "complete" are read (as the tree's
  // first member of a name would be), and a device's first "host" and "in-use".
  bool devices_seen_ = false, generation_seen_ = false, complete_seen_ = false;
  bool host_seen_ = false, in_use_seen_ = false;
  bool has_devices_ = false;
  DeviceProblem device_problem_ = DeviceProblem::none;
  std::vector<std::pair<std::size_t, std::size_t>> spans_;
  // The part and the array of strings being read (neither holds the other, nor itself).
  ServerInfo server_;
  UsbInfo usb_;
  SharingHost host_;
  DeviceInUse in_use_;
  std::vector<std::string> strings_;
};

void DocumentReader::key(std::string_view k) {
  Frame& f = frames_.back();
  const auto first = [](bool& seen, Slot slot) { return std::exchange(seen, true) ? Slot::ignored : slot; };
  switch (f.kind) {
    case Kind::list:
      f.slot = slot_of(kListKeys, k, Slot::ignored, f.next_key);
      if (f.slot == Slot::devices) f.slot = first(devices_seen_, Slot::devices);
      if (f.slot == Slot::generation) f.slot = first(generation_seen_, Slot::generation);
      if (f.slot == Slot::complete) f.slot = first(complete_seen_, Slot::complete);
      break;
    case Kind::device:
      f.slot = slot_of(kDeviceKeys, k, Slot::ignored, f.next_key);
      // A listed device's host and clients have no field: they are read on demand
      // (sharing_host, in_use_of).
      if ((f.slot == Slot::host || f.slot == Slot::in_use) && list_) f.slot = Slot::ignored;
      if (f.slot == Slot::host) f.slot = first(host_seen_, Slot::host);
      if (f.slot == Slot::in_use) f.slot = first(in_use_seen_, Slot::in_use);
      break;
    case Kind::part: {
      const Slot part = frames_[frames_.size() - 2].slot;
      const std::span<const KeySlot> keys = part == Slot::server ? std::span<const KeySlot>(kServerKeys)
                                            : part == Slot::usb  ? std::span<const KeySlot>(kUsbKeys)
                                            : part == Slot::host ? std::span<const KeySlot>(kHostKeys)
                                                                 : std::span<const KeySlot>(kInUseKeys);
      f.slot = slot_of(keys, k, Slot::refused, f.next_key);
      if (f.slot == Slot::refused) f.ok = false;
      break;
    }
    default: break;
  }
}

void DocumentReader::scalar(const Scalar& v) {
  if (frames_.empty()) return;  // the whole text is one value, not an object
  Frame& f = frames_.back();
  switch (f.kind) {
    case Kind::list:
    case Kind::device: take(f, v); break;
    case Kind::part: take_part(f, v); break;
    case Kind::devices: device_wrong(DeviceProblem::not_an_object); break;
    case Kind::strings:
      if (v.kind == Scalar::Kind::string && (f.slot != Slot::sources || rsd::model::parse_source(v.s)))
        strings_.emplace_back(v.s);
      else
        f.ok = false;
      break;
    case Kind::skipped: break;
  }
}

void DocumentReader::take(Frame& f, const Scalar& v) {
  const bool text = v.kind == Scalar::Kind::string;
  switch (f.slot) {
    case Slot::generation: list_->generation = v.kind == Scalar::Kind::whole ? v.u : 0; break;
    case Slot::complete: list_->complete = v.kind == Scalar::Kind::boolean ? v.b : true; break;
    case Slot::id: if (text) device().id = v.s; break;
    case Slot::source: if (text && rsd::model::parse_source(v.s)) device().source = v.s; break;
    case Slot::domain: if (const auto d = v.as_int()) device().domain = *d; break;
    case Slot::topic_root: if (text) device().topic_root = v.s; break;
    case Slot::name: if (text) device().name = v.s; break;
    case Slot::serial: if (text) device().serial = v.s; break;
    case Slot::product_line: if (text) device().product_line = v.s; break;
    case Slot::product_id: if (text) device().product_id = v.s; break;
    case Slot::fw_version: if (text) device().fw_version = v.s; break;
    case Slot::recovery: device().recovery = v.kind == Scalar::Kind::boolean && v.b; break;
    case Slot::first_seen: if (text) device().first_seen = v.s; break;
    case Slot::last_seen: if (text) device().last_seen = v.s; break;
    default: break;  // the list's "devices" not an array is said at the end; the rest are not taken
  }
  f.slot = Slot::ignored;
}

void DocumentReader::take_part(Frame& f, const Scalar& v) {
  const bool text = v.kind == Scalar::Kind::string;
  bool ok = text;  // most members are text
  bool required = false;
  switch (f.slot) {
    case Slot::participant_guid: if (text) server_.participant_guid = v.s; break;
    case Slot::participant_name: if (text) server_.participant_name = v.s; break;
    case Slot::writer_guid: break;
    case Slot::bus:
    case Slot::address: {
      const auto n = v.as_int();
      ok = n.has_value();
      required = true;
      if (n && f.slot == Slot::bus) usb_.bus = *n;
      break;
    }
    case Slot::port_path: required = true; if (text) usb_.port_path = v.s; break;
    case Slot::speed: required = true; if (text) usb_.speed = v.s; break;
    case Slot::vid_pid: required = true; break;
    case Slot::speed_mbps: ok = v.is_number(); break;
    case Slot::usb_text: break;
    case Slot::host_name: required = true; if (text) host_.name = v.s; break;
    case Slot::host_guid: if (text) host_.participant_guid = v.s; break;
    case Slot::clients: {
      const auto n = v.as_int();
      ok = n && *n >= 0;
      required = true;
      if (ok) in_use_.clients = static_cast<std::size_t>(*n);
      break;
    }
    default: ok = false; break;  // refused, or an array's member given a single value
  }
  if (!ok) f.ok = false;
  else if (required) ++f.counted;
}

void DocumentReader::open(bool object, std::size_t at) {
  if (frames_.empty()) {
    top_is_object_ = object;
    const Kind kind = !object ? Kind::skipped : list_ ? Kind::list : Kind::device;
    frames_.push_back({kind, Slot::ignored, true, 0, 0, at});
    return;
  }
  Frame& f = frames_.back();
  Kind kind = Kind::skipped;
  Slot slot = Slot::ignored;
  switch (f.kind) {
    case Kind::list:
      if (f.slot == Slot::devices && !object) kind = Kind::devices, has_devices_ = true;
      break;
    case Kind::devices:
      if (object) {
        kind = Kind::device;
        list_->devices.emplace_back();
        host_seen_ = in_use_seen_ = false;
      } else {
        device_wrong(DeviceProblem::not_an_object);
      }
      break;
    case Kind::device:
      if (!object && (f.slot == Slot::sources || f.slot == Slot::warnings)) kind = Kind::strings, slot = f.slot;
      if (object && (f.slot == Slot::server || f.slot == Slot::usb || f.slot == Slot::host || f.slot == Slot::in_use))
        kind = Kind::part;
      if (f.slot == Slot::recovery) device().recovery = false;
      break;
    case Kind::part:
      if (!object && (f.slot == Slot::server_addresses || f.slot == Slot::device_nodes ||
                      f.slot == Slot::host_addresses || f.slot == Slot::streaming))
        kind = Kind::strings, slot = f.slot;
      else
        f.ok = false;  // an object or array where the daemon writes none
      break;
    case Kind::strings: f.ok = false; break;
    case Kind::skipped: break;
  }
  if (kind == Kind::part) {
    switch (f.slot) {
      case Slot::server: server_ = {}; break;
      case Slot::usb: usb_ = {}; break;
      case Slot::host: host_ = {}; break;
      default: in_use_ = {}; break;
    }
  }
  if (kind == Kind::strings) strings_.clear();
  frames_.push_back({kind, slot, true, 0, 0, at});
}

void DocumentReader::close(std::size_t at) {
  const Frame f = frames_.back();
  frames_.pop_back();
  switch (f.kind) {
    case Kind::device: device_end(f, at); break;
    case Kind::part: part_end(f); break;
    case Kind::strings: strings_end(f); break;
    default: break;
  }
  if (!frames_.empty()) frames_.back().slot = frames_.back().kind == Kind::part ? Slot::refused : Slot::ignored;
}

void DocumentReader::strings_end(const Frame& strings) {
  Frame& owner = frames_.back();
  if (owner.kind == Kind::device) {
    if (strings.slot == Slot::sources && strings.ok && !strings_.empty()) device().sources = std::move(strings_);
    if (strings.slot == Slot::warnings && strings.ok) device().warnings = std::move(strings_);
    return;
  }
  if (!strings.ok) {
    owner.ok = false;
    return;
  }
  switch (strings.slot) {
    case Slot::server_addresses: server_.addresses = std::move(strings_); break;
    case Slot::host_addresses: host_.addresses = std::move(strings_), ++owner.counted; break;
    case Slot::streaming: in_use_.streaming = std::move(strings_), ++owner.counted; break;
    default: break;  // device-nodes: read, not kept
  }
}

void DocumentReader::part_end(const Frame& part) {
  const Slot which = frames_.back().slot;
  if (!part.ok || part.counted != required_of(which)) return;
  switch (which) {
    case Slot::server: device().server = std::move(server_); break;
    case Slot::usb:
      if (!usb_.bus) usb_.bus = 0;  // its count made up by an "address" twice, as the tree's reader took it
      device().usb = std::move(usb_);
      break;
    case Slot::host: single_->host = std::move(host_); break;
    case Slot::in_use: single_->in_use = std::move(in_use_); break;
    default: break;
  }
}

void DocumentReader::device_end(const Frame& frame, std::size_t at) {
  Device& d = device();
  if (d.id.empty()) device_wrong(DeviceProblem::no_id);
  if (d.sources.empty() && !d.source.empty()) d.sources.push_back(d.source);
  if (d.source.empty() && !d.sources.empty()) d.source = d.sources.front();
  d.state = d.recovery ? "recovery" : d.warnings.empty() ? "ok" : "warning";
  if (!d.warnings.empty()) d.warning = d.warnings.front();
  if (list_) spans_.emplace_back(frame.at, at);
}

[[noreturn]] void malformed(const std::string& what) {
  throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: " + what);
}

// Each device's text from the spans its reading noted in the body, each checked to
// be a whole {...}; else found by a scan.
std::vector<std::string> device_texts(std::string_view body,
                                      const std::vector<std::pair<std::size_t, std::size_t>>& spans) {
  std::vector<std::string> texts;
  texts.reserve(spans.size());
  for (auto [start, end] : spans) {
    if (start < body.size() && body[start] != '{' && start > 0 && body[start - 1] == '{') --start;
    if (end < body.size() && body[end] == '}') ++end;
    if (start >= end || end > body.size() || body[start] != '{' || body[end - 1] != '}') {
      texts.clear();
      for (auto text : array_member_elements(body, "devices")) texts.emplace_back(text);
      return texts;
    }
    texts.emplace_back(body.substr(start, end - start));
  }
  return texts;
}

}  // namespace

const char* to_string(Unread why) {
  switch (why) {
    case Unread::not_json: return "not JSON";
    case Unread::not_an_object: return "a device is not a JSON object";
    case Unread::no_id: return "a device has no \"id\"";
  }
  return "?";
}

std::optional<Unread> read_device(std::string_view text, DeviceDocument& out) {
  out = DeviceDocument();
  DocumentReader reader(nullptr, &out);
  if (json::parse(text, reader)) return Unread::not_json;
  if (!reader.top_is_object()) return Unread::not_an_object;
  if (reader.device_problem() == DocumentReader::DeviceProblem::no_id) return Unread::no_id;
  return std::nullopt;
}

Device device_from_text(std::string text) {
  DeviceDocument doc;
  if (const auto why = read_device(text, doc)) malformed(to_string(*why));
  doc.device.json = std::move(text);
  return std::move(doc.device);
}

std::optional<std::string> read_device_list(const std::string& body, const std::string& path, DeviceList& out) {
  DeviceList list;
  // Room for every device at once: a listed device's text is rarely under 200 bytes
  // (moving each as the vector grew was a part of reading a list).
  list.devices.reserve(body.size() / 200 + 1);
  DocumentReader reader(&list, nullptr);
  if (auto problem = json::parse(body, reader)) {
    if (problem->find("nested") != std::string::npos) return "GET " + path + " returned " + *problem;
    return "GET " + path + " did not return a JSON object";
  }
  if (!reader.top_is_object()) return "GET " + path + " did not return a JSON object";
  if (!reader.has_devices()) return "no \"devices\" array";
  switch (reader.device_problem()) {
    case DocumentReader::DeviceProblem::not_an_object: return to_string(Unread::not_an_object);
    case DocumentReader::DeviceProblem::no_id: malformed(to_string(Unread::no_id));
    case DocumentReader::DeviceProblem::none: break;
  }
  auto texts = device_texts(body, reader.spans());
  if (texts.size() != list.devices.size()) return "the devices could not be told apart in the text";
  for (std::size_t i = 0; i < texts.size(); ++i) list.devices[i].json = std::move(texts[i]);
  out = std::move(list);
  return std::nullopt;
}

}  // namespace rsdiscovery::detail
