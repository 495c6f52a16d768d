// rs-discover wait: return once the cameras named (or the daemon's expected ones) are
// all listed, following the event stream; on timeout say which are missing and why.
#include "common.hpp"

#include <algorithm>
#include <chrono>

namespace rsdiscover {
namespace {

using Clock = std::chrono::steady_clock;

// What the user waits for: a key (id, serial or topic-root) and how to name it.
struct Wanted {
  std::string key;
  std::string shown;
};

bool names(const rsdiscovery::Device& d, const std::string& key) {
  return d.id == key || (!d.serial.empty() && d.serial == key) || (!d.topic_root.empty() && d.topic_root == key);
}

std::vector<const Wanted*> missing_from(const std::vector<Wanted>& wanted, const std::vector<rsdiscovery::Device>& devices) {
  std::vector<const Wanted*> out;
  for (const auto& w : wanted)
    if (std::none_of(devices.begin(), devices.end(), [&](const auto& d) { return names(d, w.key); }))
      out.push_back(&w);
  return out;
}

// "wrist (realsense/D555_2): last seen 12s ago, stopping": what the daemon knows of a
// missing camera it expects.
std::string why_missing(const Wanted& w, const std::optional<rsdiscovery::Expected>& expected) {
  std::string text = w.shown;
  if (!expected) return text;
  for (const auto& m : expected->missing)
    if (m.key() == w.key) return text + ": " + missing_since(m);
  return text;
}

int run(const ParsedArgs& args) {
  const double timeout_s = args.get_seconds("timeout", 30);
  if (args.positional.empty() && !args.has("expected"))
    throw UsageError("name the cameras to wait for (id, serial or topic-root), or give --expected");
  const auto deadline = Clock::now() + std::chrono::milliseconds(static_cast<long long>(timeout_s * 1000));
  auto client = make_client(args);

  std::vector<Wanted> wanted;
  for (const auto& p : args.positional) wanted.push_back({p, p});
  std::optional<rsdiscovery::Expected> expected;
  if (args.has("expected")) {
    expected = client.expected();
    for (const auto* list : {&expected->present, &expected->missing})
      for (const auto& c : *list)
        wanted.push_back({c.key(), c.name.empty() ? c.key() : c.name + " (" + c.key() + ")"});
    if (wanted.empty()) {
      std::fprintf(stderr, "rs-discover wait: the daemon expects no cameras (its \"expect\" key is empty)\n");
      if (args.positional.empty()) return kOk;
    }
  }

  // The stream, not a poll: the watch lists once, then every change arrives as an
  // event as the daemon's table makes it.
  rsdiscovery::WatchOptions options;
  auto watch = client.watch(options);
  auto missing = missing_from(wanted, watch.devices());
  while (!missing.empty()) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
    if (left <= std::chrono::milliseconds::zero()) break;
    if (!watch.next(left)) continue;  // the deadline, or an event to look at below
    missing = missing_from(wanted, watch.devices());
  }
  watch.stop();
  if (missing.empty()) {
    if (!args.has("quiet"))
      std::printf("%zu camera%s listed\n", wanted.size(), wanted.size() == 1 ? "" : "s");
    return kOk;
  }
  // Why, where the daemon knows: its expected list carries last-seen and reason.
  try {
    expected = client.expected();
  } catch (const rsdiscovery::Error&) {
    expected.reset();  // an older daemon: the names alone
  }
  std::fprintf(stderr, "rs-discover wait: timed out after %gs; %zu of %zu camera%s missing:\n", timeout_s,
               missing.size(), wanted.size(), wanted.size() == 1 ? "" : "s");
  for (const auto* w : missing) std::fprintf(stderr, "  %s\n", why_missing(*w, expected).c_str());
  return kNotFound;
}

}  // namespace

const Command kWaitCommand = {
    "wait",
    "wait until the named or expected cameras are all listed",
    "wait [ID|SERIAL|TOPIC-ROOT...] [--expected] [--timeout S]",
    "Wait until every camera named (by id, serial or topic-root), and with --expected every\n"
    "camera the daemon's configuration expects (its \"expect\" key), is listed; it follows\n"
    "the daemon's event stream, so it returns as soon as the last one is there. Meant as\n"
    "ExecStartPre= of a robot program's unit. Exit status 0 once all are listed; 1 when\n"
    "--timeout S (default 30) passes first, with the missing cameras (and, for expected\n"
    "ones, when the daemon last listed them and why they went) on stderr; 3 when the\n"
    "daemon cannot be reached.",
    {
        {"expected", 'e', nullptr, "wait for the cameras the daemon expects too"},
        {"timeout", 't', "S", "give up after S seconds (default 30)"},
        {"quiet", 'q', nullptr, "print nothing once they are listed"},
    },
    run,
};

}  // namespace rsdiscover
