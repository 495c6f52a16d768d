// rs-discover clients: who uses a network camera (GET /v1/devices/{id}/clients), as a
// table or the daemon's JSON.
#include "common.hpp"

#include <nlohmann/json.hpp>

namespace rsdiscover {
namespace {

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out.empty() ? "-" : out;
}

int run(const ParsedArgs& args) {
  if (args.positional.size() != 1) throw UsageError("give exactly one device ID");
  auto client = make_client(args);
  const auto found = client.clients(args.positional[0]);
  if (args.has("json")) {
    std::printf("%s\n", nlohmann::json::parse(found.json).dump(output().color ? 2 : -1).c_str());
    return kOk;
  }
  if (found.clients.empty()) {
    std::printf("no client\n");
    return kOk;
  }
  Table table({"NAME", "ADDRESSES", "VENDOR", "SINCE", "STREAMS", "GUID"});
  for (const auto& c : found.clients) {
    std::string name = c.name.empty() ? "-" : c.name;
    if (!c.process.empty()) name += " (" + c.process + (c.host.empty() ? "" : "@" + c.host) + ")";
    table.add({name, joined(c.addresses), c.vendor, c.since, joined(c.streams), c.guid});
  }
  table.print(stdout);
  std::vector<std::string> streaming;
  for (const auto& [stream, readers] : found.streams)
    streaming.push_back(stream + " (" + std::to_string(readers) + (readers == 1 ? " reader)" : " readers)"));
  if (!streaming.empty()) std::printf("\nstreaming: %s\n", joined(streaming).c_str());
  return kOk;
}

}  // namespace

const Command kClientsCommand = {
    "clients",
    "show who uses a network camera",
    "clients [--json] ID",
    "Show the programs using a network (realdds) camera: every DDS participant other than\n"
    "the camera's server with a reader or writer on its topics, with its addresses, since\n"
    "when, and the streams it reads; then the streams being streamed and their readers.\n"
    "ID is an id from 'rs-discover list -q', or a serial or topic-root that names one\n"
    "camera. The daemon sees this from DDS discovery, without asking the camera. A USB\n"
    "camera is not one the daemon can tell about (exit 1). --json prints the daemon's\n"
    "document.",
    {
        {"json", 'j', nullptr, "print the clients' JSON document"},
    },
    run,
};

}  // namespace rsdiscover
