// rs-discover get: devices by id (or, failing that, by serial or topic-root).
#include "common.hpp"

#include <set>

namespace rsdiscover {
namespace {

void row(const char* key, const std::string& value) {
  if (value.empty()) return;
  std::printf("%-14s%s\n", (std::string(key) + ":").c_str(), value.c_str());
}

void show(const rsdiscovery::Device& d);

int run(const ParsedArgs& args) {
  if (args.positional.empty()) throw UsageError("give one or more device IDs");
  if (args.has("json") && args.has("format")) throw UsageError("--json and --format exclude each other");
  std::optional<Template> format;  // a bad template: exit 2 before asking the daemon
  if (args.has("format")) format.emplace(args.get("format"), device_fields());
  auto client = make_client(args);
  // The daemon looks each key up (id, serial or topic-root), waiting for its complete
  // table unless told not to; a key of several devices is an Error listing their ids.
  // Every key is looked up; those not found are named and make the exit status 1.
  std::vector<rsdiscovery::Device> found;
  int status = kOk;
  for (const auto& key : args.positional) {
    std::optional<rsdiscovery::Device> device;
    try {
      device = client.get_device(key);
    } catch (const rsdiscovery::Error& e) {
      if (e.code() != rsdiscovery::ErrorCode::not_found || e.http_status() == 409) throw;
      if (e.http_status() == 410)  // gone is not never seen: the daemon's words say why and since when
        std::fprintf(stderr, "rs-discover: %s ('rs-discover history %s' tells more)\n", e.what(), key.c_str());
      else
        report_no_device(key);
      status = kNotFound;
      continue;
    }
    found.push_back(std::move(*device));
  }
  if (args.has("json")) {
    // One document for one ID, as before; an array for several.
    rsdiscovery::json::Document out(rapidjson::kArrayType);
    for (const auto& d : found)
      out.PushBack(rsdiscovery::json::Value(rsdiscovery::json::parse_or_null(d.json), out.GetAllocator()),
                   out.GetAllocator());
    const auto& shown = args.positional.size() == 1 && found.size() == 1 ? out[0] : out;
    if (!found.empty() || args.positional.size() > 1)
      std::printf("%s\n", rsdiscovery::json::dump(shown, output().color ? 2 : -1).c_str());
    return status;
  }
  if (format) {
    print_formatted(*format, found);
    return status;
  }
  for (std::size_t i = 0; i < found.size(); ++i) {
    if (i) std::printf("\n");
    show(found[i]);
  }
  return status;
}

void show(const rsdiscovery::Device& d) {
  const auto doc = rsdiscovery::json::parse_or_null(d.json);
  row("ID", d.id);
  row("Name", d.name);
  row("Serial", d.serial);
  row("Source", device_sources(d));
  if (d.domain) row("Domain", std::to_string(*d.domain));
  row("Topic root", d.topic_root);
  row("Product line", d.product_line);
  row("Product id", d.product_id);
  row("Firmware", d.fw_version);
  std::string state = device_state(d);
  row("State", paint(state, state_color(state)));
  for (const auto& w : d.warnings) row("Warning", w);
  if (d.server) {
    row("Address", device_addresses(d));
    row("Server", d.server->participant_name);
    row("Server GUID", d.server->participant_guid);
  }
  if (d.usb) {
    row("USB port", d.usb->port_path);
    if (d.usb->bus) row("USB bus", std::to_string(*d.usb->bus));
    row("USB speed", d.usb->speed);
  }
  if (!d.first_seen.empty()) row("First seen", d.first_seen + " (" + age_since(d.first_seen) + " ago)");
  if (!d.last_seen.empty()) row("Last seen", d.last_seen + " (" + age_since(d.last_seen) + " ago)");
  static const std::set<std::string> shown = {
      "id", "name", "serial", "source", "sources", "domain", "topic-root", "product-line", "product-id",
      "fw-version", "recovery", "warnings", "server", "usb", "first-seen", "last-seen"};
  if (!doc.IsObject()) return;
  for (const auto& m : doc.GetObject()) {
    const std::string key(m.name.GetString(), m.name.GetStringLength());
    if (shown.count(key)) continue;
    const auto text = rsdiscovery::json::text(&m.value);
    row(key.c_str(), text ? std::string(*text) : rsdiscovery::json::dump(m.value));
  }
}

}  // namespace

const Command kGetCommand = {
    "get",
    "show one camera",
    "get [--json | --format TEMPLATE] [--no-wait-complete | --complete-timeout S] ID...",
    "Show cameras: every field the daemon has for each. ID is the id that 'rs-discover list -q'\n"
    "prints; a serial number or a topic-root that names one camera only works too. With\n"
    "several IDs, --json prints an array; an ID not found is named on stderr (exit status 1)\n"
    "and the others are still shown. --format prints a line per camera, as 'list --format' does.\n"
    "A camera not (yet) in the table is waited for while the daemon's first discovery runs\n"
    "(up to 5 s after it starts, --complete-timeout), unless --no-wait-complete is given.",
    {
        {"json", 'j', nullptr, "print the device's JSON document (an array of them for several IDs)"},
        kFormatOption,
        kNoWaitCompleteOption,
        kCompleteTimeoutOption,
    },
    run,
};

}  // namespace rsdiscover
