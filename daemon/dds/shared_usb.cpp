// Shared USB cameras on the wire: building a sharer's sample and reading a peer's.
#include "dds/shared_usb.hpp"

#include "rsd_model/device.hpp"

#include <arpa/inet.h>

#include <algorithm>

namespace rsd::dds {
namespace {

using nlohmann::json;

Rejected reject(const std::string& reason, std::string detail) { return {"shared-" + reason, std::move(detail)}; }

// Printable ASCII and UTF-8 alike, without control characters: a host name or a
// field a user reads, never a terminal escape.
bool plain_text(std::string_view s, std::size_t max) {
  if (s.empty() || s.size() > max || !is_valid_utf8(s)) return false;
  return std::none_of(s.begin(), s.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u < 0x20 || u == 0x7f;
  });
}

// The sharer's own id of a camera: what UsbSource names it ("usb-SERIAL", the
// serial made URL-safe, or "usb-port-PATH").
bool camera_key(std::string_view s) {
  if (s.size() <= 4 || s.size() > kMaxCameraKey || !s.starts_with("usb-")) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
           c == '~' || c == '-';
  });
}

bool ip_address(const std::string& s) {
  unsigned char buf[16];
  return inet_pton(AF_INET, s.c_str(), buf) == 1 || inet_pton(AF_INET6, s.c_str(), buf) == 1;
}

// The camera's fields the reader keeps, each checked; anything else the peer sent
// is dropped (a shared camera is this daemon's document, not the peer's).
std::optional<model::Device> camera_fields(const json& doc) {
  if (!doc.is_object()) return std::nullopt;
  const model::Device in = model::device_from_json(doc);
  if (!in.name || !plain_text(*in.name, kMaxSharedText)) return std::nullopt;
  model::Device out;
  out.source = model::Source::remote_usb;
  out.name = in.name;
  const auto text = [](const std::optional<std::string>& v, std::size_t max) {
    return v && plain_text(*v, max) ? v : std::nullopt;
  };
  out.serial = text(in.serial, 64);
  out.product_line = text(in.product_line, 64);
  out.product_id = text(in.product_id, 64);
  out.fw_version = text(in.fw_version, 64);
  out.recovery = in.recovery.value_or(false);
  if (in.usb && plain_text(in.usb->port_path, 64) && plain_text(in.usb->speed, 32) && plain_text(in.usb->vid, 8) &&
      plain_text(in.usb->pid, 8)) {
    out.usb = *in.usb;
    out.usb->sysfs_path.reset();  // a path on another host's file system says nothing here
    out.usb->device_nodes.clear();  // nor do its device files
    if (out.usb->usb_version && !plain_text(*out.usb->usb_version, 16)) out.usb->usb_version.reset();
  }
  for (const auto& w : in.warnings) {
    if (out.warnings.size() == kMaxSharedWarnings) break;
    if (plain_text(w, kMaxSharedText)) out.warnings.push_back(w);
  }
  return out;
}

}  // namespace

std::string shared_usb_id(std::string_view host, std::string_view camera) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string id(camera);
  id += '.';
  // The host's '.' is escaped too: the id's last '.' is where the host begins.
  for (const char ch : host) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-') {
      id += ch;
    } else {
      id += '~';
      id += kHex[c >> 4];
      id += kHex[c & 0xF];
    }
  }
  return id;
}

std::string shared_usb_payload(const std::string& host_name, const std::vector<std::string>& addresses,
                               const nlohmann::json& local) {
  json device = json::object();
  // The camera as its host lists it, minus what only that host's table means.
  for (const auto& [k, v] : local.items())
    if (k != model::key::id && k != model::key::source && k != model::key::sources &&
        k != model::key::first_seen && k != model::key::last_seen && k != model::key::merged_into)
      device[k] = v;
  json doc = {{"host", {{"name", host_name}, {"addresses", addresses}}}, {"device", std::move(device)}};
  return doc.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::variant<SharedCamera, Rejected> parse_shared_usb(int domain, std::string_view host, std::string_view camera,
                                                      std::uint8_t version, std::span<const std::uint8_t> data,
                                                      const std::string& participant_guid) {
  if (version != kSharedUsbVersion) return reject("version", "version " + std::to_string(version));
  if (!plain_text(host, kMaxHostKey)) return reject("bad-key", "host key not a host name");
  if (!camera_key(camera)) return reject("bad-key", "camera key not a USB camera id");
  auto parsed = parse_flexible(static_cast<std::int32_t>(DataFormat::json), data);
  if (auto* r = std::get_if<Rejected>(&parsed)) return reject(r->reason, r->detail);
  const json& doc = std::get<json>(parsed);
  if (!doc.is_object()) return reject("not-object", "the document is not an object");
  const auto h = doc.find("host");
  if (h == doc.end() || !h->is_object()) return reject("bad-host", "no host object");
  const auto name = h->find("name");
  if (name == h->end() || !name->is_string() || name->get_ref<const std::string&>() != host)
    return reject("bad-host", "host name missing or not the key's");
  model::Host out_host;
  out_host.name = std::string(host);
  if (const auto a = h->find("addresses"); a != h->end()) {
    if (!a->is_array() || a->size() > kMaxSharedAddresses) return reject("bad-host", "addresses not a short list");
    for (const auto& x : *a) {
      if (!x.is_string() || !ip_address(x.get_ref<const std::string&>()))
        return reject("bad-host", "an address is not an IP address");
      if (std::find(out_host.addresses.begin(), out_host.addresses.end(), x.get<std::string>()) ==
          out_host.addresses.end())
        out_host.addresses.push_back(x.get<std::string>());
    }
  }
  if (!participant_guid.empty()) out_host.participant_guid = participant_guid;
  const auto d = doc.find("device");
  if (d == doc.end()) return reject("bad-device", "no device object");
  auto device = camera_fields(*d);
  if (!device) return reject("bad-device", "device without a readable name");
  device->domain = domain;
  device->host = std::move(out_host);
  return SharedCamera{shared_usb_id(host, camera), model::to_json(*device)};
}

}  // namespace rsd::dds
