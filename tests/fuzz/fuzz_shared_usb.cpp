// Fuzz target for shared-usb samples (issue 25): whatever another host's daemon,
// or anyone on the domain, writes on rs-discoveryd/shared-usb, the parser answers,
// and what it accepts is a remote-usb device that serialises again, under an id
// made of its key.
//
// Input: the first byte is the version, then the host key and the camera key,
// each ended by a NUL, then the data (a missing NUL: the rest is that key).
#include "dds/shared_usb.hpp"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <string_view>

namespace {

std::string_view take(const std::uint8_t*& p, const std::uint8_t* end) {
  const auto* nul = static_cast<const std::uint8_t*>(std::memchr(p, 0, static_cast<std::size_t>(end - p)));
  const std::uint8_t* stop = nul ? nul : end;
  std::string_view s(reinterpret_cast<const char*>(p), static_cast<std::size_t>(stop - p));
  p = nul ? nul + 1 : end;
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t version = data[0];
  const std::uint8_t* p = data + 1;
  const std::uint8_t* end = data + size;
  const std::string_view host = take(p, end);
  const std::string_view camera = take(p, end);
  const auto parsed = rsd::dds::parse_shared_usb(5, host, camera, version,
                                                 std::span<const std::uint8_t>(p, static_cast<std::size_t>(end - p)),
                                                 "0110a3b1.22c44e8f.7f000001.000001c1");
  if (const auto* cam = std::get_if<rsd::dds::SharedCamera>(&parsed)) {
    (void)cam->device.dump();  // throws on invalid UTF-8: must never happen for accepted input
    if (cam->device.value("source", "") != "remote-usb" || !cam->device.contains("host")) std::abort();
    if (cam->id != rsd::dds::shared_usb_id(host, camera) || cam->id.find('/') != std::string::npos) std::abort();
  }
  return 0;
}
