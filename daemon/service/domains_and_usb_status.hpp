// The StatusView the API reads, made of the joined DDS domains, the USB watcher
// and the expected cameras, as plain status values. The service owns them; this
// only asks them.
#pragma once

#include "service/domain_set.hpp"
#include "service/expected_set.hpp"
#include "service/usb_watch.hpp"
#include "status/status_view.hpp"

#include <chrono>

namespace rsd::service {

class DomainsAndUsbStatus final : public StatusView {
 public:
  DomainsAndUsbStatus(const DomainSet& domains, const UsbWatch& usb, const ExpectedSet& expected,
                      std::chrono::milliseconds describe_wait)
      : domains_(domains), usb_(usb), expected_(expected), describe_wait_(describe_wait) {}

  std::vector<DomainStatus> domains() const override { return domains_.status(); }
  bool discovery_complete() const override { return domains_.discovery_complete(); }
  std::vector<model::Participant> participants() const override { return domains_.participants(); }
  std::optional<UsbStatus> usb() const override { return usb_.status(); }
  DeviceDescription describe(const std::string& id) const override { return domains_.describe(id, describe_wait_); }
  std::vector<model::ExpectedCamera> expected() const override { return expected_.get(); }
  std::optional<model::DeviceClients> clients(int domain, const std::string& topic_root) const override {
    return domains_.clients(domain, topic_root);
  }

 private:
  const DomainSet& domains_;
  const UsbWatch& usb_;
  const ExpectedSet& expected_;
  std::chrono::milliseconds describe_wait_;
};

}  // namespace rsd::service
