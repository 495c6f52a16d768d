// Fuzz target for the API's request path, without sockets: whatever bytes a client
// sends, the head scan gives a verdict (the same whether the bytes came at once or
// in two parts), and a request it calls complete goes through httplib's parsing and
// the daemon's routes (filters, ids, Last-Event-ID, since, the Host check) to an
// answer that is an HTTP response. The table holds a DDS, a USB and a merged camera.
#include "api/api_server.hpp"
#include "api/plain_list.hpp"
#include "api/request_head.hpp"
#include "log/log.hpp"

#include <cstdint>
#include <cstdlib>
#include <string_view>

namespace {

class NoSources final : public rsd::StatusView {
 public:
  std::vector<rsd::DomainStatus> domains() const override {
    rsd::DomainStatus d;
    d.domain = 0;
    d.state = rsd::DomainState::running;
    d.complete = true;
    return {d};
  }
  std::vector<rsd::model::Participant> participants() const override {
    rsd::model::Participant p;
    p.guid = "010f78fd.3e2482db.00000000.000001c1";
    p.vendor_id = "01.0f";
    p.vendor = rsd::model::Vendor::fast_dds;
    p.addresses = {"192.0.2.2"};
    p.device_info_writers = 2;
    p.devices = 1;
    return {p};
  }
  std::optional<rsd::UsbStatus> usb() const override { return rsd::UsbStatus{"hotplug", "", 2, 2, 0, 0}; }
  rsd::DeviceDescription describe(const std::string&) const override {
    return {rsd::DeviceDescription::Outcome::timeout, {}, "the fuzzer's cameras never answer"};
  }
};

rsd::api::ApiServer& server() {
  static rsd::SharedTable table;
  static bool seeded = [] {
    rsd::log::set_level(rsd::log::Level::error);
    table.upsert("dds-0-realsense.D455_123622270732",
                 {{"name", "Intel RealSense D455"}, {"serial", "123622270732"}, {"product-line", "D400"},
                  {"topic-root", "realsense/D455_123622270732"}, {"domain", 0}, {"source", "dds"},
                  {"server", {{"participant-guid", "01.0f"}, {"addresses", {"192.0.2.7"}}}}});
    table.upsert("usb-123622270732", {{"name", "Intel RealSense D455"}, {"serial", "123622270732"},
                                      {"product-line", "D400"}, {"source", "usb"}});
    table.upsert("usb-819612070440", {{"name", "Intel RealSense D435"}, {"serial", "819612070440"},
                                      {"product-line", "D400"}, {"source", "usb"}, {"warnings", {"usb2"}}});
    return true;
  }();
  static NoSources sources;
  static rsd::api::ApiServer api(table, sources, "0.0.0-fuzz");
  (void)seeded;
  return api;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  const rsd::api::HeadLimits limits;
  const auto whole = rsd::api::scan_request_head(in, limits);
  // Arriving in two parts (a slow client) changes nothing about the verdict.
  const auto first = rsd::api::scan_request_head(in.substr(0, size / 2), limits);
  if (first.verdict == rsd::api::HeadVerdict::incomplete) {
    const auto resumed = rsd::api::scan_request_head(in, limits, first.scanned);
    if (resumed.verdict != whole.verdict || resumed.head_length != whole.head_length ||
        resumed.body_length != whole.body_length)
      std::abort();
  }
  if (whole.verdict != rsd::api::HeadVerdict::complete) return 0;
  if (whole.head_length > size) std::abort();
  const auto request = in.substr(0, std::min(size, whole.head_length + whole.body_length));
  // A request the loop would answer past httplib (PlainList) is one httplib
  // answers as a plain list too: a 200 or a 304, on the Unix socket, and of
  // exactly the request's bytes (no body, no second request hidden behind it).
  const bool plain = rsd::api::read_plain_list(request).has_value();
  if (plain && (whole.body_length != 0 || whole.head_length != request.size())) std::abort();
  for (const bool http : {false, true}) {
    const auto answer = server().answer(request, http);
    if (!answer.empty() && answer.rfind("HTTP/1.1 ", 0) != 0) std::abort();
    if (plain && !http && answer.rfind("HTTP/1.1 200 ", 0) != 0 && answer.rfind("HTTP/1.1 304 ", 0) != 0)
      std::abort();
  }
  return 0;
}
