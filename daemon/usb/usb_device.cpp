#include "usb/usb_device.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace rsd::usb {
namespace {

std::string hex4(std::uint16_t v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04X", static_cast<unsigned>(v));
  return buf;
}

std::string trim(std::string_view s) {
  const auto ws = " \t\r\n";
  const auto b = s.find_first_not_of(ws);
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(ws);
  return std::string(s.substr(b, e - b + 1));
}

// A sysfs attribute's text (they are small), or nullopt when it cannot be read.
std::optional<std::string> read_attr(const std::filesystem::path& dir, const char* name) {
  std::ifstream in(dir / name, std::ios::binary);
  if (!in) return std::nullopt;
  std::string text(256, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  return text;
}

std::optional<long> parse_long(const std::string& text) {
  const auto t = trim(text);
  long v = 0;
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec != std::errc() || p != t.data() + t.size()) return std::nullopt;
  return v;
}

// "/dev/..." from a uevent's DEVNAME (the kernel writes it relative to /dev), or
// nothing without a plain one.
std::optional<std::string> devname_of(const std::filesystem::path& dir) {
  const auto uevent = read_attr(dir, "uevent");
  if (!uevent) return std::nullopt;
  const std::string_view text = *uevent;
  for (std::size_t at = 0; at < text.size();) {
    std::size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(at, end - at);
    at = end + 1;
    if (!line.starts_with("DEVNAME=")) continue;
    std::string name = trim(line.substr(8));
    if (name.empty() || name.find("..") != std::string::npos) return std::nullopt;
    return name.front() == '/' ? name : "/dev/" + name;
  }
  return std::nullopt;
}

}  // namespace

std::string port_path(std::uint8_t bus, const std::vector<std::uint8_t>& ports) {
  if (ports.empty()) return "usb" + std::to_string(bus);
  std::string out = std::to_string(bus) + "-";
  for (std::size_t i = 0; i < ports.size(); ++i) {
    if (i) out += '.';
    out += std::to_string(ports[i]);
  }
  return out;
}

std::string speed_name(double mbps) {
  if (mbps <= 0) return "unknown";
  if (mbps < 12) return "low";
  if (mbps < 480) return "full";
  if (mbps < 5000) return "high";
  if (mbps < 10000) return "super";
  return "super-plus";
}

std::optional<std::string> clean_serial(std::string_view raw) {
  std::string s = trim(raw);
  if (s.empty() || s.size() > 64) return std::nullopt;
  for (unsigned char c : s)
    if (c < 0x20 || c > 0x7E) return std::nullopt;
  return s;
}

std::string url_safe(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (unsigned char c : text) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '~' || c == '-';
    out += ok ? static_cast<char>(c) : '_';
  }
  return out;
}

std::string sighting_id(const UsbSighting& s) {
  if (s.serial) return "usb-" + url_safe(*s.serial);
  return "usb-port-" + port_path(s.bus, s.ports);
}

std::optional<std::string> link_warning(const UsbSighting& s, const ProductInfo& product) {
  if (!product.usb3 || s.speed_mbps <= 0 || s.speed_mbps >= 5000) return std::nullopt;
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "This USB 3 camera is connected at USB 2 speed (%g Mbit/s): depth and color "
                "streams will be limited to low resolutions and frame rates. Plug it into a "
                "USB 3 port with a USB 3 cable, without USB 2 hubs or extensions in between.",
                s.speed_mbps);
  return std::string(buf);
}

model::Device to_device(const UsbSighting& s, const ProductInfo& product) {
  model::Usb usb;
  usb.bus = s.bus;
  usb.address = s.address;
  usb.port_path = port_path(s.bus, s.ports);
  usb.speed = speed_name(s.speed_mbps);
  usb.vid = hex4(s.vid);
  usb.pid = hex4(s.pid);
  if (s.speed_mbps > 0) usb.speed_mbps = s.speed_mbps;
  if (s.bcd_usb) {
    char ver[16];
    std::snprintf(ver, sizeof ver, "%x.%02x", static_cast<unsigned>(s.bcd_usb >> 8),
                  static_cast<unsigned>(s.bcd_usb & 0xFF));
    usb.usb_version = ver;
  }
  if (!s.sysfs_path.empty()) usb.sysfs_path = s.sysfs_path;
  usb.device_nodes = s.device_nodes;

  model::Device d;
  d.source = model::Source::usb;
  d.name = std::string("Intel RealSense ") + product.name;
  d.product_id = hex4(s.pid);
  d.product_line = product.product_line;
  d.recovery = product.recovery;
  d.usb = std::move(usb);
  d.serial = s.serial;
  if (auto w = link_warning(s, product)) d.warnings.push_back(*w);
  return d;
}

nlohmann::json to_json(const UsbSighting& s, const ProductInfo& product) {
  return model::to_json(to_device(s, product));
}

SysfsInfo read_sysfs(const std::string& sysfs_root, std::uint8_t bus,
                     const std::vector<std::uint8_t>& ports, std::uint8_t address) {
  namespace fs = std::filesystem;
  SysfsInfo info;
  const fs::path link = fs::path(sysfs_root) / "bus/usb/devices" / port_path(bus, ports);
  const auto busnum = read_attr(link, "busnum");
  const auto devnum = read_attr(link, "devnum");
  if (!busnum || !devnum || parse_long(*busnum) != bus || parse_long(*devnum) != address)
    return info;
  info.matches = true;
  if (auto serial = read_attr(link, "serial")) info.serial = clean_serial(*serial);
  if (auto speed = read_attr(link, "speed")) {
    const auto t = trim(*speed);
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (end && *end == '\0' && v > 0 && v < 1e6) info.speed_mbps = v;
  }
  // The link is relative ("../../../devices/..."): resolve it by hand so the path
  // is the kernel's, whatever the process' view of the filesystem.
  std::error_code ec;
  const fs::path target = fs::read_symlink(link, ec);
  if (!ec)
    info.path = (target.is_absolute() ? target : (link.parent_path() / target)).lexically_normal().string();
  return info;
}

std::vector<std::string> device_nodes(const std::string& device_dir, std::uint8_t bus, std::uint8_t address) {
  namespace fs = std::filesystem;
  constexpr int kMaxDepth = 5;          // 2-1/2-1:1.5/0003:8086:0B5C.0001/hidraw/hidraw0
  constexpr std::size_t kMaxEntries = 4096;
  constexpr std::size_t kMaxNodes = 32;  // a D455 has about ten
  std::vector<std::string> out;
  std::error_code ec;
  if (device_dir.empty() || !fs::is_directory(device_dir, ec)) return out;  // unplugged meanwhile
  char usbfs[32];
  std::snprintf(usbfs, sizeof usbfs, "/dev/bus/usb/%03u/%03u", static_cast<unsigned>(bus),
                static_cast<unsigned>(address));
  out.push_back(devname_of(device_dir).value_or(usbfs));
  std::vector<std::string> children;
  fs::recursive_directory_iterator it(device_dir, fs::directory_options::skip_permission_denied, ec);
  std::size_t entries = 0;
  for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (++entries > kMaxEntries || children.size() >= kMaxNodes) break;
    std::error_code type_ec;
    if (it->is_symlink(type_ec) || !it->is_directory(type_ec)) continue;  // links lead out of the device
    const fs::path& dir = it->path();
    if (fs::exists(dir / "devnum", type_ec)) {  // another USB device, below a hub
      it.disable_recursion_pending();
      continue;
    }
    if (it.depth() >= kMaxDepth) it.disable_recursion_pending();
    const std::string name = dir.filename().string();
    const bool wanted = (name.starts_with("video") && name != "video4linux") || name.starts_with("media") ||
                        name.starts_with("hidraw");
    if (!wanted) continue;
    if (auto node = devname_of(dir)) children.push_back(std::move(*node));
  }
  std::sort(children.begin(), children.end());
  children.erase(std::unique(children.begin(), children.end()), children.end());
  out.insert(out.end(), children.begin(), children.end());
  return out;
}

}  // namespace rsd::usb
