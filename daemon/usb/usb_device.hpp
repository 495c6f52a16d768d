// A RealSense camera as seen on the local USB bus, and its device document for
// the table. Pure: the values come from the device descriptor (through libusb)
// and from sysfs; nothing here opens a device or talks to libusb.
#pragma once

#include "usb/realsense_ids.hpp"

#include "rsd_model/device.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rsd::usb {

struct UsbSighting {
  std::uint16_t vid = 0;
  std::uint16_t pid = 0;
  std::uint16_t bcd_usb = 0;      // USB version the device declares (0x0320: 3.2)
  std::uint8_t bus = 0;
  std::uint8_t address = 0;       // devnum
  std::vector<std::uint8_t> ports;  // from the root hub down (libusb_get_port_numbers)
  double speed_mbps = 0;          // link speed; 0: unknown
  std::optional<std::string> serial;  // the USB iSerial (sysfs "serial"), cleaned
  std::string sysfs_path;         // e.g. /sys/devices/pci0000:00/0000:00:14.0/usb2/2-1
  std::vector<std::string> device_nodes;  // device_nodes() below
};

// "2-1.4": the kernel's name for the device (and its place in the port tree).
// A root hub (no ports) is "usb2".
std::string port_path(std::uint8_t bus, const std::vector<std::uint8_t>& ports);

// "low", "full", "high", "super", "super-plus" (USB names of 1.5/12/480/5000/10000+
// Mbit/s), "unknown" for 0.
std::string speed_name(double mbps);

// A serial as read from sysfs, trimmed; nullopt unless it is 1..64 printable ASCII
// characters (a garbled serial must never be used to match two sightings).
std::optional<std::string> clean_serial(std::string_view raw);

// Keeps [A-Za-z0-9._~-], replaces anything else with '_': fit for a URL path.
std::string url_safe(std::string_view text);

// "usb-<serial>", or "usb-port-<port path>" without a usable serial. Stable across
// replugs into the same port (and, with a serial, into any port).
std::string sighting_id(const UsbSighting& s);

// The plain-language warning for a USB 3 camera on a slower link, if any.
std::optional<std::string> link_warning(const UsbSighting& s, const ProductInfo& product);

// The sighting as the API's device (source, name, serial, product-id, product-line,
// recovery, usb {...}, and warnings when there are any), and as the table's document.
model::Device to_device(const UsbSighting& s, const ProductInfo& product);
nlohmann::json to_json(const UsbSighting& s, const ProductInfo& product);

// What sysfs says about the USB device named port_path(bus, ports) under
// `sysfs_root` (normally "/sys"). `matches` is false when the directory is
// missing or holds another device (busnum/devnum differ: it was replugged since).
struct SysfsInfo {
  bool matches = false;
  std::optional<std::string> serial;
  double speed_mbps = 0;
  std::string path;  // the device's real directory, e.g. /sys/devices/.../2-1
};
SysfsInfo read_sysfs(const std::string& sysfs_root, std::uint8_t bus,
                     const std::vector<std::uint8_t>& ports, std::uint8_t address);

// The device files of the USB device whose sysfs directory is `device_dir`
// (SysfsInfo::path): its usbfs node (/dev/bus/usb/BBB/DDD) first, then the
// video, media and hidraw nodes its interfaces' drivers made (sorted), each named
// by the DEVNAME of its uevent (none when the directory is gone). A device below
// it (a hub's) is not searched. The walk is bounded (depth, entries, nodes):
// sysfs is the kernel's, but a strange tree must not hold the USB thread.
std::vector<std::string> device_nodes(const std::string& device_dir, std::uint8_t bus, std::uint8_t address);

}  // namespace rsd::usb
