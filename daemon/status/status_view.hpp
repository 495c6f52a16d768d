// What frontends see of the sources besides the table, the one interface they
// read it through: plain status values, asked for at request time from any thread. The service
// implements it over the DDS domains and the USB watcher it owns; the API knows
// nothing else about them (no DDS or USB header), and a test harness can stand in.
#pragma once

#include "status/device_description.hpp"
#include "status/domain_status.hpp"
#include "status/usb_status.hpp"

#include "rsd_model/clients.hpp"
#include "rsd_model/expected.hpp"
#include "rsd_model/participant.hpp"

#include <optional>
#include <string>
#include <vector>

namespace rsd {

class StatusView {
 public:
  virtual ~StatusView() = default;

  // Every joined domain, in no particular order.
  virtual std::vector<DomainStatus> domains() const = 0;
  // Whether every domain's first discovery is over (DomainStatus::complete of all).
  // Asked for every device list, so a source may answer it cheaper than domains().
  virtual bool discovery_complete() const {
    const auto all = domains();
    for (const auto& d : all)
      if (!d.complete) return false;
    return true;
  }
  // Every DDS participant heard on the joined domains (the daemon's own aside).
  virtual std::vector<model::Participant> participants() const = 0;
  // Nothing when USB is turned off (--no-usb, "usb": false), now.
  virtual std::optional<UsbStatus> usb() const = 0;
  // Camera Discovery of the device `id` (an entry of the table); blocks up to the
  // daemon's describe timeout.
  virtual DeviceDescription describe(const std::string& id) const = 0;
  // The cameras the configuration expects (`expect`), in its order; none by default.
  virtual std::vector<model::ExpectedCamera> expected() const { return {}; }
  // The clients of the DDS camera `topic_root` on `domain` (participants other than
  // its server on its topics); nothing when the domain has no such camera.
  virtual std::optional<model::DeviceClients> clients(int domain, const std::string& topic_root) const {
    (void)domain;
    (void)topic_root;
    return std::nullopt;
  }
};

}  // namespace rsd
