// rs-discover: ask rs-discoveryd which RealSense cameras are around.
// This file only dispatches; each subcommand is its own cmd_*.cpp.
#include "common.hpp"

#include <cstdio>
#include <cstring>

#include <unistd.h>

namespace {

using namespace rsdiscover;

const Command* const kCommands[] = {&kListCommand,    &kGetCommand,          &kDescribeCommand, &kClientsCommand,
                                    &kWatchCommand,   &kWaitCommand,         &kDomainsCommand,  &kParticipantsCommand,
                                    &kDoctorCommand,  &kHealthCommand,       &kHistoryCommand};

void usage(std::FILE* out) {
  std::fputs(
      "Usage: rs-discover [--endpoint ENDPOINT] COMMAND [options]\n\n"
      "Ask rs-discoveryd, the RealSense discovery daemon, which cameras are around\n"
      "(over DDS and USB), without waiting for discovery yourself.\n\nCommands:\n",
      out);
  for (const Command* c : kCommands) std::fprintf(out, "  %-12s %s\n", c->name, c->summary);
  std::fputs(
      "\nRun 'rs-discover COMMAND --help' for a command's options; -V, --version prints the version.\n"
      "The daemon is reached at --endpoint, else $RS_DISCOVERY_ENDPOINT, else its default\n"
      "socket ($RUNTIME_DIRECTORY/api.sock, /run/rs-discoveryd/api.sock as root,\n"
      "$XDG_RUNTIME_DIR/rs-discoveryd.sock otherwise, falling back to the system\n"
      "service's /run/rs-discoveryd/api.sock when only that one exists).\n"
      "\nExit status: 0 ok, 1 not found or timed out, 2 usage error, 3 daemon unreachable,\n"
      "4 the answer was not understood (not rs-discoveryd, version mismatch, malformed reply).\n",
      out);
}

}  // namespace

int main(int argc, char** argv) {
  // Output to a pipe or file goes out in large blocks from a buffer that exists
  // before anything else is allocated: stdio's own, made at the first write after
  // the device list was parsed and freed, cost a malloc_consolidate that showed in a
  // cold `rs-discover list` (callgrind). A terminal keeps its line buffering.
  static char out_buffer[1 << 16];
  if (!isatty(STDOUT_FILENO)) std::setvbuf(stdout, out_buffer, _IOFBF, sizeof out_buffer);
  std::vector<std::string> args(argv + 1, argv + argc);
  // Common options may come before the command: move them after it.
  std::vector<std::string> leading;
  while (!args.empty() && args[0].size() > 1 && args[0][0] == '-') {
    const std::string a = args[0];
    // Whole or a unique prefix, as getopt takes them after the command.
    const auto is = [&](const char* name) { return a.size() > 2 && std::string(name).starts_with(a); };
    if (a == "-h" || is("--help")) {
      usage(stdout);
      return kOk;
    }
    if (a == "-V" || is("--version")) {
      std::printf("rs-discover %s\n", rsdiscovery::version());
      return kOk;
    }
    leading.push_back(a);
    args.erase(args.begin());
    // --endpoint and --color take a value: as the next argument unless attached
    // (--endpoint=..., -- a unique prefix such as --end counts too).
    const auto takes_value = [&](const std::string& name) {
      return a.size() > 3 && a.find('=') == std::string::npos && name.starts_with(a.substr(2));
    };
    bool needs_value = a.starts_with("--") && (takes_value("endpoint") || takes_value("color"));
    if (needs_value) {
      if (args.empty()) {
        std::fprintf(stderr, "rs-discover: %s needs a value\n", a.c_str());
        return kUsage;
      }
      leading.push_back(args[0]);
      args.erase(args.begin());
    }
  }
  if (args.empty()) {
    usage(stderr);
    return kUsage;
  }
  std::string name = args[0];
  args.erase(args.begin());
  if (name == "help") {
    if (args.empty()) {
      usage(stdout);
      return kOk;
    }
    name = args[0];
    args = {"--help"};
  }
  const Command* command = nullptr;
  for (const Command* c : kCommands)
    if (name == c->name) command = c;
  if (!command) {
    std::fprintf(stderr, "rs-discover: unknown command '%s' (try 'rs-discover --help')\n", name.c_str());
    return kUsage;
  }
  // Before the command's own: a value-taking option at the end (list --domain) must
  // not take the common ones as its value.
  args.insert(args.begin(), leading.begin(), leading.end());
  try {
    ParsedArgs parsed = parse_args(args, command->options);
    if (parsed.has("help")) {
      print_help(*command, stdout);
      return kOk;
    }
    if (parsed.has("version")) {
      std::printf("rs-discover %s\n", rsdiscovery::version());
      return kOk;
    }
    return command->run(parsed);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "rs-discover %s: %s\nTry 'rs-discover %s --help'.\n", command->name, e.what(),
                 command->name);
    return kUsage;
  } catch (const rsdiscovery::Error& e) {
    return report(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rs-discover: %s\n", e.what());
    return kBadReply;
  }
}
