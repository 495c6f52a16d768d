// rs-discover's command line: the options every subcommand takes, parsing them the
// way GNU tools do (getopt_long), the values' checks, --color, and --help.
#include "common.hpp"

#include <getopt.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace rsdiscover {

const std::vector<OptionSpec> kCommonOptions = {
    {"endpoint", 0, "ENDPOINT",
     "the daemon: unix:/path/to/socket or http://host:port (default: $RS_DISCOVERY_ENDPOINT, "
     "else the daemon's default socket)"},
    {"color", 0, "WHEN", "colour the output: auto (on a terminal), always, never"},
    {"help", 'h', nullptr, "show this help and exit"},
    {"version", 'V', nullptr, "show rs-discover's version and exit"},
};

std::vector<OptionSpec> with_device_filters(std::vector<OptionSpec> own) {
  own.insert(own.begin(), {kDomainOption, kProductLineOption, kSourceOption, kSerialOption, kNameOption, kAddressOption,
                            kHostOption, kInUseOption, kFreeOption});
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
             "4 the answer was not understood (not rs-discoveryd, version mismatch, malformed reply).\n",
             out);
}

}  // namespace rsdiscover
