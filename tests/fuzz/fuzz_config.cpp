// Fuzz target for the configuration file: whatever the file holds, the parser either
// takes it (and then every value is in range) or says why with a ConfigError, never
// anything else, and never takes the daemon down.
#include "config/config.hpp"

#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  rsd::Config config;
  try {
    rsd::apply_config_json(text, config);
  } catch (const rsd::ConfigError&) {
    return 0;
  }
  for (int d : config.domains)
    if (d < 0 || d > rsd::kMaxDomain) std::abort();
  if (config.domains.empty() || config.max_devices_per_domain == 0 || config.max_devices_per_participant == 0 ||
      config.max_clients == 0 || config.describe_timeout_s < 1 || config.describe_timeout_s > 300)
    std::abort();
  if (!config.http_host.empty() && (config.http_port < 1 || config.http_port > 65535)) std::abort();
  return 0;
}
