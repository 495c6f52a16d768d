// rs-discover describe: what a network camera can do (Camera Discovery), as tables.
#include "common.hpp"

#include <chrono>

namespace rsdiscover {
namespace {

std::string profile_text(const rsdiscovery::StreamProfile& p) {
  if (p.format.empty() && p.width == 0) return "-";  // a motion stream: a rate only
  return std::to_string(p.width) + "x" + std::to_string(p.height) + " " + p.format;
}

bool same(const rsdiscovery::StreamProfile& a, const rsdiscovery::StreamProfile& b) {
  return a.fps == b.fps && a.format == b.format && a.width == b.width && a.height == b.height;
}

// "8500 (1..165000, step 1, default 8500)" from the option's own JSON form, whatever
// shape the server gave it.
std::string option_text(const rsdiscovery::CameraOption& o) {
  std::string out = o.value.empty() ? "-" : o.value;
  const auto doc = rsdiscovery::json::parse_or_null(o.json);
  if (doc.IsArray() && doc.Size() >= 6 && doc[2].IsNumber() && doc[3].IsNumber()) {
    using rsdiscovery::json::dump;
    out += " (" + dump(doc[2]) + ".." + dump(doc[3]) + ", step " + dump(doc[4]) + ", default " + dump(doc[5]) + ")";
  }
  return out;
}

int run(const ParsedArgs& args) {
  if (args.positional.size() != 1) throw UsageError("give exactly one device ID");
  const std::string& key = args.positional[0];
  const double timeout = args.get_seconds("timeout", 35);
  auto client = make_client(args);
  rsdiscovery::Description description;
  try {
    description = client.describe(key, std::chrono::milliseconds(static_cast<long long>(timeout * 1000)));
  } catch (const rsdiscovery::Error& e) {
    // A key the daemon has no camera for: said as 'get' says it (a camera it has that
    // cannot be described keeps the daemon's reason).
    if (e.code() != rsdiscovery::ErrorCode::not_found || std::string(e.what()).rfind("no device '", 0) != 0) throw;
    report_no_device(key);
    return kNotFound;
  }
  if (args.has("json")) {
    const auto doc = rsdiscovery::json::parse_or_null(description.json);
    std::printf("%s\n", rsdiscovery::json::dump(doc, output().color ? 2 : -1).c_str());
    return kOk;
  }
  Table streams({"STREAM", "TYPE", "SENSOR", "PROFILE", "FPS", "DEFAULT"});
  for (const auto& s : description.streams) {
    bool first = true;
    for (const auto& p : s.profiles) {
      const bool is_default = s.default_profile && same(*s.default_profile, p);
      streams.add({first ? s.name : "", first ? s.type : "", first ? s.sensor : "", profile_text(p),
                   std::to_string(p.fps), is_default ? "*" : ""});
      first = false;
    }
    if (first) streams.add({s.name, s.type, s.sensor, "-", "-", ""});
  }
  streams.print(stdout);
  Table options({"OPTION", "OF", "VALUE", "DESCRIPTION"});
  bool any = false;
  for (const auto& o : description.device_options) {
    options.add({o.name, "device", option_text(o), o.description});
    any = true;
  }
  for (const auto& s : description.streams)
    for (const auto& o : s.options) {
      options.add({o.name, s.name, option_text(o), o.description});
      any = true;
    }
  if (any) {
    std::printf("\n");
    options.print(stdout);
  }
  return kOk;
}

}  // namespace

const Command kDescribeCommand = {
    "describe",
    "show what a network camera can do",
    "describe [--json] [--timeout S] ID",
    "Show a network (realdds) camera's streams with their profiles (size, format, fps; *\n"
    "marks the default), and its device and stream options, as the camera's server declares\n"
    "them, without opening the camera. ID is an id from 'rs-discover list -q', or a serial or\n"
    "topic-root that names one camera. The first time for a camera the daemon asks its\n"
    "server (a few milliseconds; up to its describe timeout, 30 s, when the server is slow);\n"
    "later answers come from what the daemon kept. USB-only cameras cannot be described\n"
    "without opening them (exit 1). --json prints the daemon's document (extrinsics and\n"
    "presets too).",
    {
        {"json", 'j', nullptr, "print the description's JSON document"},
        {"timeout", 't', "S", "wait at most S seconds for the description (default 35)"},
    },
    run,
};

}  // namespace rsdiscover
