// Fuzz target for the client library's readers of the daemon's answers (RapidJSON,
// client/src/json.hpp): the input is a reply body, read as a device list and as every
// other document. Each reader answers or refuses with the library's Error; nothing
// crashes, recurses without bound or reads out of the body.
#include "internal.hpp"

#include <cstdint>
#include <cstdlib>
#include <string>

namespace {

template <class Read>
void read_or_refuse(Read read) {
  try {
    read();
  } catch (const rsdiscovery::Error& e) {
    if (e.code() != rsdiscovery::ErrorCode::malformed_reply) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rsdiscovery;
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::string body = text;
  DeviceList list;
  read_or_refuse([&] {
    if (!detail::read_device_list(body, "/v1/devices", list))
      for (const auto& d : list.devices)
        if (d.id.empty() || d.json.empty() || d.json.front() != '{') std::abort();
  });
  json::Document doc;
  if (json::parse(text, doc)) return 0;
  read_or_refuse([&] { (void)detail::device_from_text(text); });
  read_or_refuse([&] { (void)detail::description_from_json(doc); });
  read_or_refuse([&] { (void)detail::domain_from_json(doc); });
  read_or_refuse([&] { (void)detail::health_from_json(doc); });
  read_or_refuse([&] { (void)detail::expected_from_json(doc); });
  read_or_refuse([&] { (void)detail::participant_from_json(doc); });
  read_or_refuse([&] { (void)detail::clients_from_json(doc); });
  detail::DeviceDocument device;
  (void)detail::read_device(text, device);
  (void)detail::reports_complete(doc);
  // What is written out reads back and is written out the same (compared as text: an
  // object with a key twice is not equal to itself by RapidJSON's operator==).
  const std::string written = json::dump(doc);
  json::Document again;
  if (json::parse(written, again) || json::dump(again) != written) std::abort();
  (void)detail::same_device(text, written);
  return 0;
}
