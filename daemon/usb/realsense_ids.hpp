// The RealSense USB product table (librealsense's ids): which Intel devices are
// cameras, what they are called, and which are recovery (DFU) devices.
#pragma once

#include <cstdint>

namespace rsd::usb {

inline constexpr std::uint16_t kIntelVid = 0x8086;

struct ProductInfo {
  std::uint16_t pid;
  const char* name;          // without the "Intel RealSense " prefix
  const char* product_line;  // "D400", "D500", "SR300", "L500", "T200"
  bool recovery;             // a device in recovery (firmware update) mode
  bool usb3;                 // a camera that needs a USB 3 link for its full rates
};

// The RealSense product for this vendor/product id, or nullptr: other Intel
// devices (and everything else) are not cameras.
const ProductInfo* find_product(std::uint16_t vid, std::uint16_t pid);

}  // namespace rsd::usb
