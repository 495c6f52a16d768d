// rs-discover clients: who uses a camera. A network camera's clients come from the
// daemon (GET /v1/devices/{id}/clients); a USB camera's are the processes holding its
// device nodes, which only this host's /proc tells (usb_holders.hpp).
#include "common.hpp"
#include "usb_holders.hpp"

#include <algorithm>

namespace rsdiscover {
namespace {

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out.empty() ? "-" : out;
}

bool has_source(const rsdiscovery::Device& d, const std::string& source) {
  return d.source == source || std::find(d.sources.begin(), d.sources.end(), source) != d.sources.end();
}

// The camera's device nodes as the daemon found them in sysfs ("usb"."device-nodes").
std::vector<std::string> device_nodes(const rsdiscovery::Device& d) {
  const auto doc = rsdiscovery::json::parse_or_null(d.json);
  return rsdiscovery::json::texts(rsdiscovery::json::find(rsdiscovery::json::find(doc, "usb"), "device-nodes"));
}

// --json's document: the daemon's, with the USB holders added. Its keys are in byte
// order at every level, as in all of rs-discover's JSON: the daemon writes them so,
// and the holders' keys are put in their place among them.
std::string clients_json(const std::optional<rsdiscovery::CameraClients>& dds, const UsbHolders* holders,
                         int indent) {
  namespace json = rsdiscovery::json;
  json::Document doc = dds ? json::parse_or_null(dds->json) : json::Document(rapidjson::kObjectType);
  if (!doc.IsObject()) doc.SetObject();
  if (holders) {
    auto& a = doc.GetAllocator();
    const auto str = [&](const std::string& s) {
      return json::Value(s.data(), static_cast<rapidjson::SizeType>(s.size()), a);
    };
    json::Value list(rapidjson::kArrayType);
    for (const auto& h : holders->holders) {
      json::Value nodes(rapidjson::kArrayType);
      for (const auto& n : h.nodes) nodes.PushBack(str(n), a);
      json::Value holder(rapidjson::kObjectType);
      holder.AddMember("command", str(h.command), a);
      holder.AddMember("nodes", nodes, a);
      holder.AddMember("pid", h.pid, a);
      holder.AddMember("uid", h.uid, a);
      holder.AddMember("user", str(h.user), a);
      list.PushBack(holder, a);
    }
    // Into their place among the daemon's keys, in place of any of the same name.
    json::Value sorted(rapidjson::kObjectType);
    const auto add_holders = [&] {
      sorted.AddMember("holders", list, a);
      sorted.AddMember("holders-complete", holders->unreadable == 0, a);
    };
    bool added = false;
    for (auto& m : doc.GetObject()) {
      const std::string_view key(m.name.GetString(), m.name.GetStringLength());
      if (key == "holders" || key == "holders-complete") continue;
      if (!added && key > "holders") add_holders(), added = true;
      sorted.AddMember(m.name, m.value, a);
    }
    if (!added) add_holders();
    static_cast<json::Value&>(doc).Swap(sorted);  // the values only: the allocator stays doc's
  }
  return json::dump(doc, indent);
}

void print_dds_clients(const rsdiscovery::CameraClients& found) {
  if (found.clients.empty()) {
    std::printf("no client\n");
    return;
  }
  Table table({"NAME", "ADDRESSES", "VENDOR", "SINCE", "STREAMS", "GUID"});
  for (const auto& c : found.clients) {
    // A ROS 2 node's participant is named "/": its nodes say who it is.
    std::string name = !c.ros_nodes.empty() ? joined(c.ros_nodes) : c.name.empty() ? "-" : c.name;
    if (!c.process.empty()) name += " (" + c.process + (c.host.empty() ? "" : "@" + c.host) + ")";
    table.add({name, joined(c.addresses), c.vendor, c.since, joined(c.streams), c.guid});
  }
  table.print(stdout);
  std::vector<std::string> streaming;
  for (const auto& [stream, readers] : found.streams)
    streaming.push_back(stream + " (" + std::to_string(readers) + (readers == 1 ? " reader)" : " readers)"));
  if (!streaming.empty()) std::printf("\nstreaming: %s\n", joined(streaming).c_str());
}

void print_usb_holders(const UsbHolders& found) {
  if (found.holders.empty()) {
    std::printf("no process holds it open\n");
  } else {
    Table table({"PID", "USER", "COMMAND", "NODES"});
    for (const auto& h : found.holders) table.add({std::to_string(h.pid), h.user, h.command, joined(h.nodes)});
    table.print(stdout);
  }
}

void warn_unreadable(const UsbHolders& found) {
  if (found.unreadable == 0) return;
  std::fprintf(stderr,
               "rs-discover: the open files of %zu process%s of other users could not be read: only yours "
               "are shown; root sees every holder (sudo rs-discover clients ...)\n",
               found.unreadable, found.unreadable == 1 ? "" : "es");
}

int run(const ParsedArgs& args) {
  if (args.positional.size() != 1) throw UsageError("give exactly one device ID");
  auto client = make_client(args);
  const auto device = client.get_device(args.positional[0]);
  const bool network = device.domain.has_value();
  const bool usb = has_source(device, "usb");
  if (!network && !usb) {  // remote-usb: its holders are processes of the host that has it
    const auto host = rsdiscovery::sharing_host(device);
    std::fprintf(stderr, "rs-discover: %s is a USB camera of host %s: run 'rs-discover clients %s' there\n",
                 device.id.c_str(), host && !host->name.empty() ? host->name.c_str() : "(unnamed)", device.id.c_str());
    return kNotFound;
  }
  std::optional<rsdiscovery::CameraClients> dds;
  if (network) dds = client.clients(device.id);
  std::optional<UsbHolders> holders;
  if (usb) {
    const auto nodes = device_nodes(device);
    if (nodes.empty())
      std::fprintf(stderr, "rs-discover: the daemon names no device node of %s yet: nothing to look for\n",
                   device.id.c_str());
    holders = find_usb_holders(nodes);
  }
  if (args.has("json")) {
    std::printf("%s\n", clients_json(dds, holders ? &*holders : nullptr, output().color ? 2 : -1).c_str());
  } else {
    if (dds) print_dds_clients(*dds);
    if (dds && holders) std::printf("\nheld on USB:\n");
    if (holders) print_usb_holders(*holders);
  }
  if (holders) warn_unreadable(*holders);
  return kOk;
}

}  // namespace

const Command kClientsCommand = {
    "clients",
    "show who uses a camera",
    "clients [--json] ID",
    "Show who uses a camera. ID is an id from 'rs-discover list -q', or a serial or\n"
    "topic-root that names one camera.\n"
    "A network (realdds) camera: every DDS participant other than the camera's server with\n"
    "a reader or writer on its topics, with its addresses, since when, and the streams it\n"
    "reads; then the streams being streamed and their readers. The daemon sees this from\n"
    "DDS discovery, without asking the camera.\n"
    "A USB camera on this host: the processes holding one of its device nodes open\n"
    "(/dev/bus/usb/BBB/DDD, its /dev/video*, /dev/media*, /dev/hidraw*), with their pid,\n"
    "user and command line, found in /proc as fuser(1) finds them. Without root only your\n"
    "own processes can be read: a note on stderr says how many were not.\n"
    "Another host's USB camera (remote-usb): run it on that host (exit 1).\n"
    "--json prints the daemon's document ({\"clients\": [...], \"streams\": {...}}), with\n"
    "\"holders\": [{\"pid\", \"uid\", \"user\", \"command\", \"nodes\"}] and \"holders-complete\"\n"
    "(false when some processes could not be read) for a USB camera.",
    {
        {"json", 'j', nullptr, "print the clients' JSON document"},
    },
    run,
};

}  // namespace rsdiscover
