// The USB source's status value lives in status/ (shared with the frontends,
// which include no USB header); this name stays for the USB code.
#pragma once

#include "status/usb_status.hpp"

namespace rsd::usb {
using UsbStatus = rsd::UsbStatus;
}  // namespace rsd::usb
