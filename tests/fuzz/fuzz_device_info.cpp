// Fuzz target for device-info parsing: whatever a DDS peer sends, the parser
// returns a value, and what it accepts can be serialised again (the API does
// exactly that for every device in the table).
//
// With clang: -fsanitize=fuzzer gives a libFuzzer binary (see tests/fuzz/README.md).
// Otherwise replay_main.cpp runs the corpus and seeded mutations of it under
// ctest, in the sanitizer build too.
#include "dds/device_info.hpp"

#include <cstdint>
#include <cstdlib>
#include <span>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // First byte picks the data_format (JSON, CBOR, CUSTOM, or out of range).
  const auto format = static_cast<std::int32_t>(data[0] % 4);
  const auto parsed = rsd::dds::parse_device_info(format, std::span<const std::uint8_t>(data + 1, size - 1));
  if (const auto* info = std::get_if<rsd::dds::DeviceInfo>(&parsed)) {
    (void)info->fields.dump();  // throws on invalid UTF-8: must never happen for accepted input
    if (info->topic_root.empty()) std::abort();
    (void)rsd::dds::device_id(0, info->topic_root);
  }
  return 0;
}
