#include "usb/realsense_ids.hpp"

#include <array>

namespace rsd::usb {
namespace {
// From the table in shared/realdds-wire.md. Recovery devices update firmware over
// USB 2 as well, and 0AD6 is the USB 2 variant: no USB 3 expectation for those.
constexpr std::array kProducts{
    ProductInfo{0x0AD1, "D400", "D400", false, true},
    ProductInfo{0x0AD2, "D410", "D400", false, true},
    ProductInfo{0x0AD3, "D415", "D400", false, true},
    ProductInfo{0x0AD4, "D430", "D400", false, true},
    ProductInfo{0x0AD5, "D430 with Tracking Module", "D400", false, true},
    ProductInfo{0x0AD6, "USB2", "D400", false, false},
    ProductInfo{0x0ADB, "D4XX Recovery", "D400", true, false},
    ProductInfo{0x0ADC, "D4XX USB2 Recovery", "D400", true, false},
    ProductInfo{0x0AF2, "IMU", "D400", false, true},
    ProductInfo{0x0AF6, "D420", "D400", false, true},
    ProductInfo{0x0AFE, "D420 with Tracking Module", "D400", false, true},
    ProductInfo{0x0AFF, "D410 with Tracking Module", "D400", false, true},
    ProductInfo{0x0B00, "D400 with Tracking Module", "D400", false, true},
    ProductInfo{0x0B01, "D430 with Tracking and RGB Modules", "D400", false, true},
    ProductInfo{0x0B03, "D460", "D400", false, true},
    ProductInfo{0x0B07, "D435", "D400", false, true},
    ProductInfo{0x0B0C, "DS5U", "D400", false, true},
    ProductInfo{0x0B3A, "D435I", "D400", false, true},
    ProductInfo{0x0B49, "F416", "D400", false, true},
    ProductInfo{0x0B4B, "D430I", "D400", false, true},
    ProductInfo{0x0B52, "F416 with RGB Module", "D400", false, true},
    ProductInfo{0x0B5B, "D405", "D400", false, true},
    ProductInfo{0x0B5C, "D455", "D400", false, true},
    ProductInfo{0x1155, "D421", "D400", false, true},
    ProductInfo{0x0B56, "D555", "D500", false, true},
    ProductInfo{0x0ADE, "D555 Recovery", "D500", true, false},
    ProductInfo{0x0AA5, "SR300", "SR300", false, true},
    ProductInfo{0x0B64, "L515", "L500", false, true},
    ProductInfo{0x0B37, "T265", "T200", false, true},
};
}  // namespace

const ProductInfo* find_product(std::uint16_t vid, std::uint16_t pid) {
  if (vid != kIntelVid) return nullptr;
  for (const auto& p : kProducts)
    if (p.pid == pid) return &p;
  return nullptr;
}

}  // namespace rsd::usb
