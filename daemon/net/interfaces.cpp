#include "net/interfaces.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace rsd::net {
namespace {

bool matches_any(const std::string& name, const std::vector<std::string>& patterns) {
  return std::any_of(patterns.begin(), patterns.end(),
                     [&](const std::string& p) { return fnmatch(p.c_str(), name.c_str(), 0) == 0; });
}

// Interface names come from the kernel (at most 15 characters, no '/' or
// whitespace), but they go into XML: anything that is not plain is escaped.
std::string xml_attribute(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace

std::vector<std::string> default_excluded_interfaces() {
  return {"docker*", "veth*", "virbr*", "br-*", "lxcbr*", "lxdbr*", "podman*", "cni*", "flannel*", "vnet*"};
}

std::vector<NetInterface> select_interfaces(const std::vector<NetInterface>& all, const InterfaceRules& rules) {
  std::vector<NetInterface> out;
  for (const auto& i : all) {
    if (!i.up || !i.running || i.ipv4.empty()) continue;
    if (rules.include.empty()) {
      if (i.loopback || !i.multicast || matches_any(i.name, rules.exclude)) continue;
    } else if (!matches_any(i.name, rules.include)) {
      continue;
    }
    out.push_back(i);
  }
  // Nothing usable (no network yet, or the interfaces named are not there):
  // loopback, so local peers still meet, and never what Cyclone DDS would pick by
  // itself, which could be an interface the rules leave out.
  if (out.empty())
    for (const auto& i : all)
      if (i.loopback && i.up && !i.ipv4.empty()) out.push_back(i);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  for (auto& i : out) std::sort(i.ipv4.begin(), i.ipv4.end());
  return out;
}

std::string cyclone_interfaces_xml(const std::vector<NetInterface>& chosen) {
  if (chosen.empty()) return "";
  std::string xml = "<General><Interfaces>";
  for (const auto& i : chosen) xml += "<NetworkInterface name=\"" + xml_attribute(i.name) + "\"/>";
  return xml + "</Interfaces></General>";
}

bool cyclone_config_names_interfaces(const std::string& config) {
  std::string text = config;
  // CYCLONEDDS_URI and the option may hold several fragments separated by commas,
  // each XML, a file URI or (as Cyclone also takes) a bare file path. A piece of
  // XML split at a comma inside it names no file and reads as nothing.
  std::size_t pos = 0;
  while (pos <= config.size()) {
    const std::size_t end = std::min(config.find(',', pos), config.size());
    std::string piece = config.substr(pos, end - pos);
    piece.erase(0, piece.find_first_not_of(" \t\r\n"));
    piece.erase(piece.find_last_not_of(" \t\r\n") + 1);
    if (piece.rfind("file://", 0) == 0) piece.erase(0, 7);
    if (!piece.empty() && piece.find('<') == std::string::npos && piece.find('>') == std::string::npos) {
      std::ifstream file(piece);
      std::stringstream body;
      body << file.rdbuf();
      text += body.str();
    }
    pos = end + 1;
  }
  return text.find("NetworkInterface") != std::string::npos;  // also the older NetworkInterfaceAddress
}

std::string describe(const std::vector<NetInterface>& chosen) {
  if (chosen.empty()) return "none";
  std::string out;
  for (const auto& i : chosen) {
    if (!out.empty()) out += ", ";
    out += i.name + " (";
    for (std::size_t n = 0; n < i.ipv4.size(); ++n) out += (n ? " " : "") + i.ipv4[n];
    out += ")";
  }
  return out;
}

}  // namespace rsd::net
