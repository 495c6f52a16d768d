// rs-discover health: is the daemon up, which version, how many devices.
#include "common.hpp"

namespace rsdiscover {
namespace {

int run(const ParsedArgs& args) {
  if (!args.positional.empty()) throw UsageError("unexpected argument '" + args.positional[0] + "'");
  auto client = make_client(args);
  auto h = client.health();
  bool ok = h.status == "ok";
  if (args.has("json")) {
    std::printf("%s\n", h.json.c_str());
  } else {
    std::printf("%s: rs-discoveryd %s at %s, %llu device%s%s\n",
                paint(h.status, ok ? color::green : color::red).c_str(),
                h.version.empty() ? "(version unknown)" : h.version.c_str(),
                client.endpoint().to_string().c_str(), static_cast<unsigned long long>(h.devices),
                h.devices == 1 ? "" : "s", h.complete ? "" : " so far (first discovery still running)");
  }
  return ok ? kOk : kNotFound;
}

}  // namespace

const Command kHealthCommand = {
    "health",
    "check that the daemon answers",
    "health [--json]",
    "Check that rs-discoveryd answers: print its status, version and device count. The exit\n"
    "status is 0 when it reports ok, 1 when it answers but is not ok, 3 when it cannot be\n"
    "reached.",
    {
        {"json", 'j', nullptr, "print the /healthz JSON"},
    },
    run,
};

}  // namespace rsdiscover
