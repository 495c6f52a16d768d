// rs-discover list: the devices the daemon knows now, as a table or JSON.
#include "common.hpp"

#include <chrono>
#include <string_view>

namespace rsdiscover {
namespace {

// ", in use" (", in use: Depth, Color" while streamed): a network camera with a client
// (its "in-use"; `rs-discover clients ID` says who). Parsed only when it is there.
std::string in_use_marker(const rsdiscovery::Device& d) {
  // Looked for from its '-' on: string_view::find goes by memchr to each place of the
  // first letter, and a document has a quote every few bytes, a '-' in a few places.
  const std::string_view text(d.json);
  bool listed = false;
  for (auto i = text.find("-use\":"); i != std::string_view::npos && !listed; i = text.find("-use\":", i + 1))
    listed = i >= 3 && text.substr(i - 3, 3) == "\"in";
  if (!listed) return "";
  const auto doc = rsdiscovery::json::parse_or_null(d.json);
  const auto* in_use = rsdiscovery::json::find(doc, "in-use");
  if (!in_use || !in_use->IsObject()) return "";
  std::string out = ", in use";
  const auto* s = rsdiscovery::json::find(*in_use, "streaming");
  if (s && s->IsArray() && !s->Empty()) {
    out += ":";
    for (rapidjson::SizeType i = 0; i < s->Size(); ++i)
      if (const auto name = rsdiscovery::json::text(&(*s)[i])) out += (i ? ", " : " ") + std::string(*name);
  }
  return out;
}

// A field's text moved into its cell (the device is not read again), or "-".
std::string taken_or_dash(std::string& field) { return field.empty() ? "-" : std::move(field); }

int run(const ParsedArgs& args) {
  if (!args.positional.empty()) throw UsageError("unexpected argument '" + args.positional[0] + "'");
  auto filter = filter_from(args);
  std::optional<Template> format;  // a bad template: exit 2 before asking the daemon
  if (args.has("format")) format.emplace(args.get("format"), device_fields());
  int wait = args.get_int("wait", 0, 0, 100000);
  double timeout = args.get_seconds("timeout", 10);
  if (args.has("timeout") && !args.has("wait")) throw UsageError("--timeout goes with --wait");
  auto client = make_client(args);

  std::vector<rsdiscovery::Device> devices;
  bool complete = true;
  std::uint64_t generation = 0;
  if (wait > 0) {
    auto ms = std::chrono::milliseconds(static_cast<long long>(timeout * 1000));
    // Feedback on stderr while waiting: each time the count moves short of the goal.
    std::optional<std::size_t> said;
    auto got = client.wait_until(
        filter,
        [&](const std::vector<rsdiscovery::Device>& v) {
          if (v.size() >= static_cast<std::size_t>(wait)) return true;
          if (said != v.size())
            std::fprintf(stderr, "rs-discover: waiting up to %gs for %d device%s (%zu present)\n", timeout, wait,
                         wait == 1 ? "" : "s", v.size());
          said = v.size();
          return false;
        },
        ms);
    if (!got) {
      auto now = client.list_devices(filter);
      std::fprintf(stderr, "rs-discover: timed out after %gs waiting for %d device%s (%zu present)\n", timeout,
                   wait, wait == 1 ? "" : "s", now.size());
      return kNotFound;
    }
    devices = std::move(*got);
    // The API's answer, generation and all, taken now that the wait is over (it holds
    // what the wait saw, or newer).
    if (args.has("json")) {
      auto list = client.list(filter);
      devices = std::move(list.devices);
      complete = list.complete;
      generation = list.generation;
    }
  } else {
    // The table (or -q) reads a few keys of each camera: asked for those alone, the
    // daemon sends and this parses about half of each document
    // (bench/results/profile-cli-list.txt). --json and --format get whole ones.
    std::vector<std::string> fields;
    if (args.has("quiet") && !args.has("json")) {
      fields = {"id"};  // --host is the daemon's filter too (DeviceFilter::host)
    } else if (!args.has("json") && !format) {
      fields = {"name", "serial", "source", "sources", "domain", "usb", "host", "server.addresses", "first-seen",
                "recovery", "warnings", "in-use"};
      if (args.has("wide")) fields.insert(fields.end(), {"product-id", "fw-version"});
    }
    auto list = client.list(filter, fields);  // waits for the complete table, unless told not to
    devices = std::move(list.devices);
    complete = list.complete;
    generation = list.generation;
  }
  if (!complete) warn_incomplete();

  if (args.has("json")) {
    std::string out = "{\"complete\":";
    out += complete ? "true" : "false";
    out += ",\"devices\":[";
    for (std::size_t i = 0; i < devices.size(); ++i) {
      if (i) out += ',';
      out += devices[i].json;
    }
    out += "],\"generation\":" + std::to_string(generation) + "}\n";
    std::fputs(out.c_str(), stdout);
    return kOk;
  }
  if (args.has("quiet")) {
    for (const auto& d : devices) std::printf("%s\n", d.id.c_str());
    exit_now(kOk);
  }
  if (format) {
    print_formatted(*format, devices);
    return kOk;
  }
  bool wide = args.has("wide");
  std::vector<std::string> headers = {"NAME", "SERIAL", "SOURCE", "DOMAIN/PORT", "ADDRESS", "STATE", "AGE"};
  if (wide) headers.insert(headers.end(), {"PRODUCT-ID", "FW", "ID"});
  Table table(headers);
  table.reserve_rows(devices.size());
  for (auto& d : devices) {  // each cell made in its place, the name and serial moved there
    const std::string state = device_state(d);
    table.cell(taken_or_dash(d.name));
    table.cell(taken_or_dash(d.serial));
    table.cell(device_sources(d));
    table.cell(device_location(d));
    table.cell(device_addresses(d));
    table.cell(state + in_use_marker(d), state_color(state));
    table.cell(age_since(d.first_seen));
    if (wide) {
      table.cell(d.product_id.empty() ? "-" : d.product_id);
      table.cell(d.fw_version.empty() ? "-" : d.fw_version);
      table.cell(d.id);
    }
  }
  table.print(stdout);
  exit_now(kOk);
}

}  // namespace

const Command kListCommand = {
    "list",
    "list the cameras the daemon knows now",
    "list [--json | -q | -w | --format TEMPLATE] [--no-headers] [-d N]... [-p LINE] [-s dds|usb|remote-usb]\n"
    "       [--serial SERIAL] [-n TEXT] [-a ADDR] [--host NAME] [--in-use | --free] [--wait N [--timeout S]]\n"
    "       [--no-wait-complete | --complete-timeout S]",
    "List the cameras rs-discoveryd knows now: one line each, with where it is (DDS domain or\n"
    "USB port), its network address and how long it has been seen. With --wait, first wait\n"
    "until at least N cameras (that match the filters) are present.\n"
    "In the first seconds after the daemon starts its table is not complete yet; list waits\n"
    "for it (up to 5 s, --complete-timeout), unless --no-wait-complete is given. An answer\n"
    "taken before it is complete comes with a warning on stderr.\n"
    "--format prints one line per camera from a template of its fields, for example\n"
    "  rs-discover list --format '{serial}\\t{name}\\t{fw-version}'\n"
    "with any key of the camera's JSON document, a nested one with dots ({server.addresses},\n"
    "{usb.port-path}; lists are joined by commas), or {state}, {location}, {address},\n"
    "{sources}, {age} as the table shows them. A field no camera has is an error (exit 2).",
    with_device_filters({
        {"json", 'j', nullptr, "print JSON: {\"complete\": true, \"devices\": [...], \"generation\": N}, as the API gives it"},
        {"quiet", 'q', nullptr, "print only the device ids, one a line"},
        {"wide", 'w', nullptr, "add the PRODUCT-ID, FW and ID columns"},
        kFormatOption,
        kNoHeadersOption,
        {"wait", 0, "N", "wait until at least N matching devices are present"},
        {"timeout", 't', "S", "give up waiting after S seconds (default 10; exit status 1)"},
        kNoWaitCompleteOption,
        kCompleteTimeoutOption,
    }),
    run,
};

}  // namespace rsdiscover
