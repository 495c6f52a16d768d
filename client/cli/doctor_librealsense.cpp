// rs-discover doctor: what librealsense on this host will see of the network cameras
// the daemon lists, read from the librealsense configuration of the user who runs it
// (and under sudo of the invoking user and of root), and --fix-librealsense.
//
// As librealsense reads it (src/context.cpp, src/dds/rsdds-device-factory.cpp,
// third-party/rsutils/src/special-folder.cpp and json.cpp): the file is
// get_special_folder(app_data) + "realsense-config.json", on Linux $HOME (else the
// passwd entry's home) + "/.realsense-config.json"; a file that does not parse is
// ignored (the defaults); its "context" object holds "dds": {"enabled" (default
// false), "domain" (default 0)} and "device-mask" (default 0xff), which keeps a DDS
// camera of product line D400 only with bit 0x02, D500 with 0x20, any other with 0x01.
#include "doctor.hpp"
#include "files.hpp"

#include <rapidjson/error/en.h>

#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <map>
#include <optional>

namespace rsdiscover::doctor {
namespace {

namespace json = rsdiscovery::json;

constexpr unsigned kMaskAny = 0xff;

// device-mask's bit for a DDS camera's product line, as librealsense tests it.
unsigned line_bit(const std::string& product_line) {
  return product_line == "D400" ? 0x02u : product_line == "D500" ? 0x20u : 0x01u;
}

struct Cameras {
  std::size_t count = 0;
  int domain = 0;         // the domain most of them are on (librealsense joins one)
  std::size_t on_domain = 0;
  unsigned bits = 0;      // device-mask bits they need
  std::string lines;      // their product lines, for messages
};

Cameras network_cameras(const std::vector<rsdiscovery::Device>& devices,
                        const std::vector<rsdiscovery::DomainStatus>& domains) {
  Cameras c;
  std::map<int, std::size_t> per_domain;
  for (const auto& d : devices) {
    if (d.source != "dds" || !d.domain) continue;  // remote-usb is no realdds camera
    ++c.count;
    ++per_domain[*d.domain];
    c.bits |= line_bit(d.product_line);
  }
  for (const auto& [domain, n] : per_domain)
    if (n > c.on_domain) c.domain = domain, c.on_domain = n;
  if (per_domain.empty() && !domains.empty()) c.domain = domains.front().domain;
  for (unsigned b : {0x02u, 0x20u, 0x01u})
    if (c.bits & b) c.lines += (c.lines.empty() ? "" : ", ") + std::string(b == 0x02 ? "D400" : b == 0x20 ? "D500" : "other");
  return c;
}

struct Account {
  std::string user, home;
  uid_t uid = 0;
  gid_t gid = 0;
};

// Whose librealsense runs here: the caller's ($HOME first, as librealsense reads it);
// under sudo the invoking user's too, whose programs run without sudo.
std::vector<Account> accounts() {
  std::vector<Account> out;
  const passwd* me = getpwuid(geteuid());
  Account self{me ? me->pw_name : std::to_string(geteuid()), "", geteuid(), getegid()};
  const char* home = std::getenv("HOME");
  self.home = home && *home ? home : me ? me->pw_dir : "";
  const char* sudo_user = std::getenv("SUDO_USER");
  if (geteuid() == 0 && sudo_user && *sudo_user && std::string(sudo_user) != self.user)
    if (const passwd* u = getpwnam(sudo_user)) out.push_back({u->pw_name, u->pw_dir, u->pw_uid, u->pw_gid});
  // sudo that keeps HOME (older Ubuntu) makes root read the invoking user's file: once.
  if (!self.home.empty() && (out.empty() || out.front().home != self.home)) out.push_back(self);
  return out;
}

struct Config {
  Account account;
  std::string path;
  enum class State { missing, broken, read } state = State::missing;
  std::string error;  // broken: the parser's words
  json::Document doc;  // as the file has it, its keys in its order
};

// Why `text` is not JSON, with where: what a user needs to mend the file. RapidJSON
// is asked where only when json::parse's own checks passed and RapidJSON refused the
// text itself ("not JSON"): the text it refuses before (numbers it may not be given)
// is not handed to it again.
std::string parse_error(std::string_view text, const std::string& why) {
  if (why != "not JSON") return why;
  json::Document doc;
  doc.Parse<rapidjson::kParseIterativeFlag | rapidjson::kParseFullPrecisionFlag |
            rapidjson::kParseValidateEncodingFlag>(text.data(), text.size());
  if (!doc.HasParseError()) return why;
  const auto before = text.substr(0, doc.GetErrorOffset());
  const auto line = 1 + std::count(before.begin(), before.end(), '\n');
  const auto line_start = before.rfind('\n');
  const auto column = before.size() - (line_start == std::string_view::npos ? 0 : line_start + 1) + 1;
  std::string words = rapidjson::GetParseError_En(doc.GetParseError());
  if (!words.empty() && words.back() == '.') words.pop_back();  // mid-sentence here
  if (!words.empty()) words[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(words[0])));
  return why + ": " + words + " at line " + std::to_string(line) + ", column " + std::to_string(column);
}

Config read_config(const Account& a) {
  Config c{a, a.home + "/.realsense-config.json", Config::State::missing, "", json::Document(rapidjson::kObjectType)};
  const auto file = read_file(c.path);
  if (!file) return c;
  const std::string_view text = without_bom(*file);
  if (const auto why = json::parse(text, c.doc)) {
    c.state = Config::State::broken;
    c.error = parse_error(text, *why);
    c.doc.SetObject();
  } else {
    c.state = Config::State::read;
  }
  return c;
}

// The settings librealsense takes from the file's "context".
struct Settings {
  bool enabled = false;
  int domain = 0;
  unsigned mask = kMaskAny;
  bool mask_set = false;
};

Settings settings_of(const Config& c) {
  Settings s;
  if (c.state != Config::State::read) return s;
  const auto* ctx = json::find(c.doc, "context");
  const auto* dds = json::find(ctx, "dds");
  if (const auto e = json::boolean(json::find(dds, "enabled"))) s.enabled = *e;
  if (const auto* d = json::find(dds, "domain"); d && d->IsInt64()) s.domain = static_cast<int>(d->GetInt64());
  if (const auto m = json::unsigned_integer(json::find(ctx, "device-mask"))) {
    s.mask = static_cast<unsigned>(*m);
    s.mask_set = true;
  }
  return s;
}

// The member `key` of `object`, made an object unless it is one; a new one goes last,
// after the user's keys.
json::Value& object_member(json::Value& object, const char* key, json::Document::AllocatorType& a) {
  auto it = object.FindMember(key);
  if (it == object.MemberEnd()) {
    object.AddMember(json::Value(key, a), json::Value(rapidjson::kObjectType), a);
    it = object.MemberEnd() - 1;
  }
  if (!it->value.IsObject()) it->value.SetObject();
  return it->value;
}

// Sets `key` of `object` to `value`, where it is, or last.
void set_member(json::Value& object, const char* key, json::Value value, json::Document::AllocatorType& a) {
  if (auto it = object.FindMember(key); it != object.MemberEnd()) it->value = value;
  else object.AddMember(json::Value(key, a), value, a);
}

std::string hex(unsigned v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%x", v);
  return buf;
}

// What is wrong for these cameras, one sentence each; empty: librealsense sees them.
std::vector<std::string> problems(const Config& c, const Settings& s, const Cameras& cams) {
  std::vector<std::string> out;
  if (c.state == Config::State::missing)
    out.push_back("there is no " + c.path + ", so DDS stays off (librealsense's default)");
  else if (c.state == Config::State::broken)
    out.push_back(c.path + " does not parse (" + c.error + "), so librealsense ignores it and DDS stays off");
  else if (!s.enabled)
    out.push_back(c.path + " leaves DDS off (context.dds.enabled is not true)");
  if (s.enabled && s.domain != cams.domain)
    out.push_back(c.path + " sets DDS domain " + std::to_string(s.domain) + "; the cameras are on domain " +
                  std::to_string(cams.domain));
  if ((s.mask & cams.bits) != cams.bits)
    out.push_back(c.path + "'s context.device-mask " + hex(s.mask) + " leaves out product line " + cams.lines +
                  " (needs " + hex(s.mask | cams.bits) + ")");
  return out;
}

}  // namespace

void check_librealsense(Report& r, const std::vector<rsdiscovery::Device>& devices,
                        const std::vector<rsdiscovery::DomainStatus>& domains) {
  const auto cams = network_cameras(devices, domains);
  for (const auto& a : accounts()) {
    const auto c = read_config(a);
    const auto s = settings_of(c);
    const auto found = problems(c, s, cams);
    const std::string who = "librealsense programs of " + a.user;
    if (cams.count == 0) {
      r.add(Verdict::info, "librealsense",
            who + (found.empty() ? " would see network cameras on domain " + std::to_string(s.domain)
                                 : ": " + found.front()) + " (no network camera listed now)");
      continue;
    }
    if (found.empty()) {
      r.add(Verdict::ok, "librealsense", who + " see the " + std::to_string(cams.on_domain) +
                                             " network camera(s) on DDS domain " + std::to_string(cams.domain) +
                                             " (" + c.path + ")");
      continue;
    }
    std::string text = who + " will not see the " + std::to_string(cams.on_domain) +
                       " network camera(s) the daemon lists on domain " + std::to_string(cams.domain) + ": ";
    for (std::size_t i = 0; i < found.size(); ++i) text += (i ? "; " : "") + found[i];
    text += ". Fix: {\"context\": {\"dds\": {\"enabled\": true, \"domain\": " + std::to_string(cams.domain) + "}" +
            (s.mask_set && (s.mask & cams.bits) != cams.bits ? ", \"device-mask\": " + std::to_string(s.mask | cams.bits)
                                                              : std::string()) +
            "}} in " + c.path + ", or 'rs-discover doctor --fix-librealsense' (keeps the rest, and a backup)";
    // No file at all is librealsense's default, which a host whose programs use no
    // librealsense keeps: said, with its fix, without failing the doctor. A file that
    // is there asks for DDS and does not get it: a likely cause.
    r.add(c.state == Config::State::missing ? Verdict::info : Verdict::warn, "librealsense", text);
  }
}

int fix_librealsense(const std::vector<rsdiscovery::Device>& devices,
                     const std::vector<rsdiscovery::DomainStatus>& domains) {
  const auto cams = network_cameras(devices, domains);
  int status = kOk;
  for (const auto& a : accounts()) {
    auto c = read_config(a);
    const auto s = settings_of(c);
    if (problems(c, s, cams).empty()) {
      std::printf("%s: nothing to change\n", c.path.c_str());
      continue;
    }
    // Only the keys librealsense needs; anything else in the file stays as it was.
    if (c.state != Config::State::read || !c.doc.IsObject()) c.doc.SetObject();
    auto& alloc = c.doc.GetAllocator();
    auto& ctx = object_member(c.doc, "context", alloc);
    auto& dds = object_member(ctx, "dds", alloc);
    set_member(dds, "enabled", json::Value(true), alloc);
    if (s.domain != cams.domain || dds.HasMember("domain")) set_member(dds, "domain", json::Value(cams.domain), alloc);
    if (s.mask_set && (s.mask & cams.bits) != cams.bits)
      set_member(ctx, "device-mask", json::Value(s.mask | cams.bits), alloc);
    // What the line below says of the mask, as the file has it now.
    std::optional<unsigned> mask;
    if (const auto* m = json::find(ctx, "device-mask"); m && m->IsInt64()) mask = static_cast<unsigned>(m->GetInt64());
    else if (m && m->IsUint64()) mask = static_cast<unsigned>(m->GetUint64());

    std::string backup;
    if (c.state != Config::State::missing) {
      backup = c.path + ".bak";
      for (int n = 1; access(backup.c_str(), F_OK) == 0; ++n) backup = c.path + ".bak." + std::to_string(n);
      if (std::rename(c.path.c_str(), backup.c_str()) != 0) {
        std::fprintf(stderr, "rs-discover: cannot back up %s: %s\n", c.path.c_str(), std::strerror(errno));
        status = kNotFound;
        continue;
      }
    }
    const std::string tmp = c.path + ".tmp";
    if (!write_file(tmp, json::dump(c.doc, 4) + "\n")) {
      std::fprintf(stderr, "rs-discover: cannot write %s: %s\n", tmp.c_str(), std::strerror(errno));
      status = kNotFound;
      continue;
    }
    // Under sudo the invoking user's file stays theirs.
    if (geteuid() == 0 && a.uid != 0 && chown(tmp.c_str(), a.uid, a.gid) != 0)
      std::fprintf(stderr, "rs-discover: cannot give %s to %s: %s\n", tmp.c_str(), a.user.c_str(), std::strerror(errno));
    if (std::rename(tmp.c_str(), c.path.c_str()) != 0) {
      std::fprintf(stderr, "rs-discover: cannot write %s: %s\n", c.path.c_str(), std::strerror(errno));
      status = kNotFound;
      continue;
    }
    std::printf("%s: DDS on, domain %d%s%s\n", c.path.c_str(), cams.domain,
                mask ? (", device-mask " + hex(*mask)).c_str() : "",
                backup.empty() ? "" : (" (the previous file is " + backup + ")").c_str());
  }
  return status;
}

}  // namespace rsdiscover::doctor
