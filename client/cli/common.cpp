// The shared part of rs-discover: option parsing, errors, tables, colour, times.
#include "common.hpp"

#include <nlohmann/json.hpp>

#include <getopt.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <ctime>

namespace rsdiscover {

using rsdiscovery::ErrorCode;

const std::vector<OptionSpec> kCommonOptions = {
    {"endpoint", 0, "ENDPOINT",
     "the daemon: unix:/path/to/socket or http://host:port (default: $RS_DISCOVERY_ENDPOINT, "
     "else the daemon's default socket)"},
    {"color", 0, "WHEN", "colour the output: auto (on a terminal), always, never"},
    {"help", 'h', nullptr, "show this help and exit"},
    {"version", 'V', nullptr, "show rs-discover's version and exit"},
};

std::vector<OptionSpec> with_device_filters(std::vector<OptionSpec> own) {
  own.insert(own.begin(), {kDomainOption, kProductLineOption, kSourceOption, kSerialOption, kNameOption, kAddressOption});
  return own;
}

Output& output() {
  static Output o;
  return o;
}

std::string ParsedArgs::get(const std::string& name, const std::string& fallback) const {
  auto it = values.find(name);
  return it == values.end() ? fallback : it->second;
}

int ParsedArgs::get_int(const std::string& name, int fallback, int min, int max) const {
  auto it = values.find(name);
  if (it == values.end()) return fallback;
  const std::string& text = it->second;
  char* end = nullptr;
  errno = 0;
  long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end || errno || v < min || v > max)
    throw UsageError("--" + name + " wants a whole number from " + std::to_string(min) + " to " +
                     std::to_string(max) + ", not '" + text + "'");
  return static_cast<int>(v);
}

std::vector<int> ParsedArgs::get_ints(const std::string& name, int min, int max) const {
  std::vector<int> out;
  auto it = all.find(name);
  if (it == all.end()) return out;
  for (const auto& v : it->second) {
    ParsedArgs one;
    one.values[name] = v;
    out.push_back(one.get_int(name, 0, min, max));
  }
  return out;
}

double ParsedArgs::get_seconds(const std::string& name, double fallback) const {
  auto it = values.find(name);
  if (it == values.end()) return fallback;
  const std::string& text = it->second;
  char* end = nullptr;
  double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end || !std::isfinite(v) || v < 0 || v > 1e7)
    throw UsageError("--" + name + " wants seconds (a number >= 0), not '" + text + "'");
  return v;
}

ParsedArgs parse_args(const std::vector<std::string>& args, const std::vector<OptionSpec>& specs) {
  // glibc's getopt_long, so the command line reads as every GNU tool's does:
  // bundled short options (-qw), attached values (-d121, --domain=121), unique
  // prefixes of long options (--prod), "--" ending the options, options after
  // operands. A repeated option keeps every value (ParsedArgs::all).
  std::vector<const OptionSpec*> known;
  for (const auto* list : {&specs, &kCommonOptions})
    for (const auto& s : *list) known.push_back(&s);
  std::vector<option> longopts;
  std::string shortopts = ":";  // ':' first: a missing value is reported as ':', not '?'
  constexpr int kLongOnly = 0x100;  // getopt's value of an option by its index, past any char
  for (std::size_t i = 0; i < known.size(); ++i) {
    const int has_arg = known[i]->value ? required_argument : no_argument;
    longopts.push_back({known[i]->name, has_arg, nullptr, kLongOnly + static_cast<int>(i)});
    if (known[i]->short_name) shortopts += std::string(1, known[i]->short_name) + (known[i]->value ? ":" : "");
  }
  longopts.push_back({nullptr, 0, nullptr, 0});

  std::vector<std::string> storage;
  storage.reserve(args.size() + 1);
  storage.push_back("rs-discover");
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : storage) argv.push_back(a.data());
  argv.push_back(nullptr);

  const auto by_short = [&](int c) -> const OptionSpec* {
    for (const auto* s : known)
      if (s->short_name == c) return s;
    return nullptr;
  };
  ParsedArgs out;
  optind = 0;  // glibc: start afresh (tests and callers may parse more than once)
  opterr = 0;  // the errors below say more than getopt's own
  const int argc = static_cast<int>(storage.size());
  for (;;) {
    int index = -1;
    const int c = getopt_long(argc, argv.data(), shortopts.c_str(), longopts.data(), &index);
    if (c == -1) break;
    // getopt permutes argv (operands move to the end): read it, not `storage`.
    const std::string given = optind - 1 < argc ? argv[static_cast<std::size_t>(optind - 1)] : "";
    if (c == '?') {
      if (optopt && optopt < kLongOnly) throw UsageError(std::string("unknown option '-") + char(optopt) + "'");
      // A long option that is unknown, or a prefix of several.
      std::string name = given.substr(0, given.find('='));
      std::vector<std::string> matches;
      for (const auto* s : known)
        if (name.size() > 2 && std::string(s->name).starts_with(name.substr(2))) matches.push_back("--" + std::string(s->name));
      if (matches.size() > 1) throw UsageError("option '" + name + "' is ambiguous: " + join(matches, ", "));
      if (name.starts_with("--") && given.find('=') != std::string::npos && matches.size() == 1)
        throw UsageError(matches[0] + " takes no value");
      throw UsageError("unknown option '" + name + "'");
    }
    if (c == ':') {
      const OptionSpec* s = optopt >= kLongOnly ? known[static_cast<std::size_t>(optopt - kLongOnly)] : by_short(optopt);
      throw UsageError("--" + std::string(s ? s->name : "?") + " needs a value (" + (s ? s->value : "") + ")");
    }
    const OptionSpec* s = c >= kLongOnly ? known[static_cast<std::size_t>(c - kLongOnly)] : by_short(c);
    if (!s) throw UsageError("unknown option '" + given + "'");
    const std::string value = s->value ? optarg : "1";
    out.values[s->name] = value;
    out.all[s->name].push_back(value);
  }
  for (int i = optind; i < argc; ++i) out.positional.push_back(argv[static_cast<std::size_t>(i)]);
  output().headers = !out.has("no-headers");
  std::string when = out.get("color", "auto");
  if (when == "always") {
    output().color = true;
  } else if (when == "never") {
    output().color = false;
  } else if (when == "auto") {
    const char* no_color = std::getenv("NO_COLOR");
    const char* term = std::getenv("TERM");
    output().color = isatty(STDOUT_FILENO) && !(no_color && *no_color) &&
                     !(term && std::strcmp(term, "dumb") == 0);
  } else {
    throw UsageError("--color wants auto, always or never, not '" + when + "'");
  }
  return out;
}

void print_help(const Command& c, std::FILE* out) {
  std::fprintf(out, "Usage: rs-discover %s\n\n%s\n\nOptions:\n", c.usage, c.description);
  auto show = [&](const std::vector<OptionSpec>& list) {
    for (const auto& s : list) {
      std::string left = s.short_name ? std::string("-") + s.short_name + ", " : "    ";
      left += "--" + std::string(s.name);
      if (s.value) left += " " + std::string(s.value);
      if (left.size() < 26)
        std::fprintf(out, "  %-26s%s\n", left.c_str(), s.help);
      else
        std::fprintf(out, "  %s\n  %-26s%s\n", left.c_str(), "", s.help);
    }
  };
  show(c.options);
  show(kCommonOptions);
  std::fputs("\nExit status: 0 ok, 1 not found or timed out, 2 usage error, 3 daemon unreachable,\n"
             "4 the daemon's answer was not understood (version mismatch, malformed reply).\n",
             out);
}

rsdiscovery::ClientOptions client_options(const ParsedArgs& args) {
  rsdiscovery::ClientOptions options;
  if (args.has("no-wait-complete") && args.has("complete-timeout"))
    throw UsageError("--no-wait-complete and --complete-timeout exclude each other");
  if (args.has("no-wait-complete")) {
    options.complete_timeout = std::chrono::milliseconds::zero();
  } else if (args.has("complete-timeout")) {
    options.complete_timeout =
        std::chrono::milliseconds(static_cast<long long>(args.get_seconds("complete-timeout", 0) * 1000));
  }
  // A busy daemon is waited for as it asks; the user sees why the command pauses.
  options.on_busy = [](const std::string& why) { std::fprintf(stderr, "rs-discover: %s\n", why.c_str()); };
  return options;
}

namespace {
// 0 when something accepts a connection on the Unix socket at `path`, else errno.
int connect_error(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) return ENAMETOOLONG;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return errno;
  const int rc = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  const int err = rc == 0 ? 0 : errno;
  ::close(fd);
  return err;
}
}  // namespace

rsdiscovery::Client make_client(const ParsedArgs& args) {
  const auto options = client_options(args);
  const char* env = std::getenv("RS_DISCOVERY_ENDPOINT");
  if (args.has("endpoint") || (env && *env)) return rsdiscovery::Client(args.get("endpoint"), options);
  // No endpoint given: the daemon's default socket, or, when there is no socket there
  // or nothing listens on it, the daemon's default HTTP address on loopback (a daemon
  // run as another user, in a container, or with a socket made elsewhere). Only a
  // missing or refused socket: a permission error says which group to join.
  auto socket = rsdiscovery::Endpoint::default_socket();
  const int err = connect_error(socket.path);
  if (err != ENOENT && err != ENOTDIR && err != ECONNREFUSED) return rsdiscovery::Client(socket, options);
  const auto http = rsdiscovery::Endpoint::parse("127.0.0.1");  // the daemon's default port
  const std::string why = err == ECONNREFUSED ? "nothing listens on " + socket.path : "no socket at " + socket.path;
  try {
    auto quick = options;
    quick.connect_timeout = std::chrono::milliseconds(500);
    rsdiscovery::Client client(http, quick);
    client.health();  // it is rs-discoveryd that answers there
    std::fprintf(stderr, "rs-discover: %s; using %s\n", why.c_str(), http.to_string().c_str());
    return rsdiscovery::Client(http, options);
  } catch (const rsdiscovery::Error& e) {
    const std::string there = e.code() == rsdiscovery::ErrorCode::not_running
                                  ? "nothing answers at " + http.to_string()
                                  : http.to_string() + " is not rs-discoveryd (" + e.what() + ")";
    throw rsdiscovery::Error(rsdiscovery::ErrorCode::not_running,
                             "cannot reach rs-discoveryd: " + why + ", and " + there +
                                 " (is it running? Give its endpoint with --endpoint or RS_DISCOVERY_ENDPOINT)");
  }
}

rsdiscovery::DeviceFilter filter_from(const ParsedArgs& args) {
  rsdiscovery::DeviceFilter f;
  f.domains = args.get_ints("domain", 0, 232);
  f.serial = args.get("serial");
  f.name = args.get("name");
  f.address = args.get("address");
  f.product_line = args.get("product-line");
  f.source = args.get("source");
  if (!f.source.empty() && f.source != "dds" && f.source != "usb")
    throw UsageError("--source wants dds or usb, not '" + f.source + "'");
  return f;
}

void warn_incomplete() {
  // stderr, and still exit 0: the answer is right about every camera it lists, and
  // scripts reading stdout keep working; a human learns why one may be missing.
  std::fputs("rs-discover: warning: rs-discoveryd has not finished its first discovery (it started moments "
             "ago); cameras may be missing from this answer\n",
             stderr);
}

int report(const rsdiscovery::Error& e) {
  std::fprintf(stderr, "rs-discover: %s\n", e.what());
  switch (e.code()) {
    case ErrorCode::not_found:
    case ErrorCode::timeout:
      return kNotFound;
    case ErrorCode::bad_endpoint:
      return kUsage;
    case ErrorCode::not_running:
    case ErrorCode::permission_denied:
    case ErrorCode::cancelled:
      return kUnreachable;
    case ErrorCode::http_error:
      // The daemon understood and could not: a camera it cannot describe (409:
      // recovery firmware, a serial of several) or that did not answer in time (504,
      // 503): not found or timed out, as the exit status has it.
      if (e.http_status() == 409 || e.http_status() == 503 || e.http_status() == 504) return kNotFound;
      return kBadReply;
    case ErrorCode::malformed_reply:
    case ErrorCode::version_mismatch:
      return kBadReply;
  }
  return kBadReply;
}

namespace color {
const char* const bold = "\033[1m";
const char* const green = "\033[32m";
const char* const yellow = "\033[33m";
const char* const red = "\033[31m";
const char* const dim = "\033[2m";
}  // namespace color

std::string paint(const std::string& text, const char* code) {
  if (!output().color || !code) return text;
  return code + text + "\033[0m";
}

std::string join(const std::vector<std::string>& parts, const std::string& sep) {
  std::string out;
  for (const auto& p : parts) {
    if (!out.empty()) out += sep;
    out += p;
  }
  return out;
}

std::string device_state(const rsdiscovery::Device& d) { return d.state.empty() ? "ok" : d.state; }

const char* state_color(const std::string& state) {
  if (state == "ok") return color::green;
  if (state == "recovery") return color::yellow;
  return color::red;
}

std::string device_location(const rsdiscovery::Device& d) {
  std::vector<std::string> parts;
  if (d.domain) parts.push_back(std::to_string(*d.domain));
  if (d.usb) {
    std::string port = d.usb->port_path;
    if (port.empty() && d.usb->bus) port = "bus " + std::to_string(*d.usb->bus);
    parts.push_back("usb " + (port.empty() ? std::string("?") : port));
  }
  return parts.empty() ? "-" : join(parts, ", ");
}

std::string device_addresses(const rsdiscovery::Device& d) {
  if (!d.server || d.server->addresses.empty()) return "-";
  return join(d.server->addresses, ",");
}

std::string device_sources(const rsdiscovery::Device& d) {
  if (d.sources.size() > 1) return join(d.sources, "+");
  return d.source.empty() ? "-" : d.source;
}

std::optional<double> parse_iso8601(const std::string& text) {
  // "2026-11-24T10:09:54.065Z", "+02:00"-style offsets too. By hand with
  // from_chars and the chrono calendar: sscanf and timegm for the AGE column took
  // a sixth of a cold `rs-discover list` of 100 cameras (callgrind).
  const char* p = text.data();
  const char* const end = p + text.size();
  const auto number = [&](int digits, int& out) {
    if (end - p < digits) return false;
    const auto r = std::from_chars(p, p + digits, out);
    if (r.ec != std::errc() || r.ptr != p + digits) return false;
    p += digits;
    return true;
  };
  const auto expect = [&](char c) { return p < end && *p++ == c; };
  int y, mo, d, h, mi, whole_s;
  if (!number(4, y) || !expect('-') || !number(2, mo) || !expect('-') || !number(2, d) || !expect('T') ||
      !number(2, h) || !expect(':') || !number(2, mi) || !expect(':') || !number(2, whole_s))
    return std::nullopt;
  const std::chrono::year_month_day date{std::chrono::year{y}, std::chrono::month{static_cast<unsigned>(mo)},
                                         std::chrono::day{static_cast<unsigned>(d)}};
  if (!date.ok() || h > 23 || mi > 59 || whole_s > 60) return std::nullopt;
  double fraction = 0;
  if (p < end && *p == '.') {
    double scale = 0.1;
    for (++p; p < end && *p >= '0' && *p <= '9'; ++p, scale /= 10) fraction += (*p - '0') * scale;
  }
  double offset = 0;  // "Z" or none: UTC
  if (p < end && (*p == '+' || *p == '-')) {
    const int sign = *p++ == '+' ? 1 : -1;
    int oh = 0, om = 0;
    if (!number(2, oh)) return std::nullopt;
    if (p < end && *p == ':') ++p;
    if (p < end) number(2, om);
    offset = sign * (oh * 3600 + om * 60);
  }
  const auto days = std::chrono::sys_days{date}.time_since_epoch().count();
  return static_cast<double>(days) * 86400 + h * 3600 + mi * 60 + whole_s + fraction - offset;
}

std::string age_since(const std::string& iso8601) {
  auto then = parse_iso8601(iso8601);
  if (!then) return "-";
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  double secs = static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) / 1e9 - *then;
  if (secs < 0) secs = 0;
  auto n = static_cast<long long>(secs);
  if (n < 60) return std::to_string(n) + "s";
  if (n < 3600) return std::to_string(n / 60) + "m";
  if (n < 86400) return std::to_string(n / 3600) + "h";
  return std::to_string(n / 86400) + "d";
}

void Table::add(std::vector<std::string> cells, std::vector<const char*> colors) {
  cells.resize(headers_.size());
  colors.resize(headers_.size(), nullptr);
  rows_.push_back(std::move(cells));
  colors_.push_back(std::move(colors));
}

namespace {
// Display width of UTF-8 text: one column per code point (device names are ASCII
// in practice; this keeps any other text from breaking the alignment badly).
std::size_t width(const std::string& s) {
  std::size_t n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}
}  // namespace

const std::vector<std::string>& device_fields() {
  static const std::vector<std::string> fields = {
      "id", "name", "serial", "product-line", "product-id", "fw-version", "topic-root", "source", "sources",
      "domain", "recovery", "warnings", "merged-into", "first-seen", "last-seen", "server",
      "server.participant-name", "server.participant-guid", "server.writer-guid", "server.addresses", "usb",
      "usb.bus", "usb.address", "usb.port-path", "usb.speed", "usb.speed-mbps", "usb.vid", "usb.pid",
      "usb.usb-version", "usb.sysfs-path", "state", "location", "address", "age"};
  return fields;
}

const std::vector<std::string>& participant_fields() {
  static const std::vector<std::string> fields = {
      "domain", "guid", "name", "vendor", "vendor-id", "addresses", "host", "process", "pid", "lease-seconds",
      "state", "first-seen", "last-seen", "device-info-writers", "devices", "silent-writers", "never-announced",
      "topic-roots", "endpoints"};
  return fields;
}

std::optional<std::string> device_computed(const rsdiscovery::Device& d, const std::string& field) {
  if (field == "state") return device_state(d);
  if (field == "location") return device_location(d);
  if (field == "address") return device_addresses(d);
  if (field == "sources") return device_sources(d);
  if (field == "age") return age_since(d.first_seen);
  return std::nullopt;
}

void print_formatted(const Template& tmpl, const std::vector<rsdiscovery::Device>& devices) {
  std::vector<nlohmann::json> docs;
  docs.reserve(devices.size());
  for (const auto& d : devices) docs.push_back(nlohmann::json::parse(d.json, nullptr, false));
  tmpl.check(docs);
  std::string out;
  for (std::size_t i = 0; i < devices.size(); ++i)
    out += tmpl.render(docs[i], [&](const std::string& f) { return device_computed(devices[i], f); }) + "\n";
  std::fputs(out.c_str(), stdout);
}

std::string value_text(const nlohmann::json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) return v.get<std::string>();
  if (v.is_array()) {
    std::vector<std::string> parts;
    for (const auto& item : v) parts.push_back(value_text(item));
    return join(parts, ",");
  }
  return v.dump();
}

namespace {
// The value at a dotted path ("server.addresses"), or nullptr.
const nlohmann::json* at_path(const nlohmann::json& doc, const std::string& path) {
  const nlohmann::json* v = &doc;
  std::size_t from = 0;
  for (;;) {
    if (!v->is_object()) return nullptr;
    const auto dot = path.find('.', from);
    const auto it = v->find(path.substr(from, dot == std::string::npos ? std::string::npos : dot - from));
    if (it == v->end()) return nullptr;
    v = &*it;
    if (dot == std::string::npos) return v;
    from = dot + 1;
  }
}
}  // namespace

Template::Template(const std::string& tmpl, std::vector<std::string> known) : known_(std::move(known)) {
  std::string literal;
  for (std::size_t i = 0; i < tmpl.size(); ++i) {
    const char c = tmpl[i];
    const char next = i + 1 < tmpl.size() ? tmpl[i + 1] : '\0';
    if ((c == '{' && next == '{') || (c == '}' && next == '}')) {
      literal += c;
      ++i;
    } else if (c == '{') {
      const auto close = tmpl.find('}', i);
      if (close == std::string::npos) throw UsageError("--format: '{' at " + std::to_string(i + 1) + " is never closed");
      if (!literal.empty()) pieces_.push_back({false, std::move(literal)});
      literal.clear();
      pieces_.push_back({true, tmpl.substr(i + 1, close - i - 1)});
      i = close;
    } else if (c == '}') {
      throw UsageError("--format: '}' at " + std::to_string(i + 1) + " closes nothing (write }} for a brace)");
    } else if (c == '\\' && (next == 'n' || next == 't')) {
      literal += next == 'n' ? '\n' : '\t';
      ++i;
    } else {
      literal += c;
    }
  }
  if (!literal.empty()) pieces_.push_back({false, std::move(literal)});
}

void Template::check(const std::vector<nlohmann::json>& docs) const {
  for (const auto& piece : pieces_) {
    if (!piece.field) continue;
    if (std::find(known_.begin(), known_.end(), piece.text) != known_.end()) continue;
    if (std::any_of(docs.begin(), docs.end(), [&](const nlohmann::json& d) { return at_path(d, piece.text); }))
      continue;
    throw UsageError("--format: unknown field '{" + piece.text + "}'; the fields are {" + join(known_, "}, {") +
                     "} (and any other key a document has)");
  }
}

std::string Template::render(const nlohmann::json& doc,
                             const std::function<std::optional<std::string>(const std::string&)>& computed) const {
  std::string out;
  for (const auto& piece : pieces_) {
    if (!piece.field) {
      out += piece.text;
      continue;
    }
    if (computed)
      if (auto v = computed(piece.text)) {
        out += *v;
        continue;
      }
    if (const auto* v = at_path(doc, piece.text)) out += value_text(*v);
  }
  return out;
}

void Table::print(std::FILE* out) const {
  std::vector<std::size_t> w(headers_.size());
  for (std::size_t i = 0; i < headers_.size(); ++i) w[i] = width(headers_[i]);
  for (const auto& row : rows_)
    for (std::size_t i = 0; i < row.size(); ++i) w[i] = std::max(w[i], width(row[i]));
  auto line = [&](const std::vector<std::string>& cells, const std::vector<const char*>* colors,
                  const char* all) {
    std::string text;
    for (std::size_t i = 0; i < cells.size(); ++i) {
      bool last = i + 1 == cells.size();
      const char* code = colors ? (*colors)[i] : all;
      text += paint(cells[i], code);
      if (!last) text.append(w[i] - width(cells[i]) + 2, ' ');
    }
    text += '\n';
    std::fputs(text.c_str(), out);
  };
  if (output().headers) line(headers_, nullptr, color::bold);
  for (std::size_t r = 0; r < rows_.size(); ++r) line(rows_[r], &colors_[r], nullptr);
}

}  // namespace rsdiscover
