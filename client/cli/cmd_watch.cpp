// rs-discover watch: one line per change of the device table, until interrupted.
#include "common.hpp"

#include <pthread.h>
#include <signal.h>
#include <sys/time.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <chrono>
#include <ctime>
#include <thread>

namespace rsdiscover {
namespace {

const char* event_color(rsdiscovery::Event::Type t) {
  switch (t) {
    case rsdiscovery::Event::Type::added: return color::green;
    case rsdiscovery::Event::Type::changed: return color::yellow;
    case rsdiscovery::Event::Type::removed: return color::red;
  }
  return nullptr;
}

// Local date and time to the millisecond: a watch runs for days, and its lines
// end up in logs next to journalctl's.
std::string clock_now() {
  timeval tv{};
  gettimeofday(&tv, nullptr);
  std::tm tm{};
  localtime_r(&tv.tv_sec, &tm);
  char buf[48];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02d %02d:%02d:%02d.%03d", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(tv.tv_usec / 1000));
  return buf;
}

using rsdiscovery::json::Value;

// A network camera's clients coming and going, from its "in-use" before and now
// (null: no client): "a client came (2 clients, streaming Depth)", "its last client left".
std::string in_use_change(const Value& old, const Value& now) {
  const auto count = [](const Value& u) -> std::uint64_t {
    return rsdiscovery::json::unsigned_integer(rsdiscovery::json::find(u, "clients")).value_or(0);
  };
  const std::uint64_t was = count(old), is = count(now);
  std::string out;
  if (is > was) out = is - was == 1 ? "a client came" : std::to_string(is - was) + " clients came";
  else if (is < was) out = is == 0 ? "its last client left" : was - is == 1 ? "a client left" : std::to_string(was - is) + " clients left";
  else out = "its streams changed";
  if (is == 0) return out;
  const auto* streaming = rsdiscovery::json::find(now, "streaming");
  const std::string streams = streaming ? value_text(*streaming) : "";
  return out + " (" + std::to_string(is) + (is == 1 ? " client" : " clients") +
         (streams.empty() ? ", not streaming" : ", streaming " + streams) + ")";
}

std::string_view name_of(const rapidjson::Value::Member& m) { return {m.name.GetString(), m.name.GetStringLength()}; }

// What a `changed` event changed, in words, from the device as last seen:
// "fw-version 5.16.0.1 -> 5.16.1.0, now served by server-b (10.0.0.2), entered
// recovery". Nested fields by their dotted names, lists joined by commas; the times
// seen are left out.
std::string changes(const std::string& before_json, const std::string& after_json) {
  const auto before = rsdiscovery::json::parse_or_null(before_json);
  const auto after = rsdiscovery::json::parse_or_null(after_json);
  if (!before.IsObject() || !after.IsObject()) return "";
  const Value none;
  const auto get = [&](const Value& doc, std::string_view key) -> const Value& {
    const auto* v = rsdiscovery::json::find(doc, key);
    return v ? *v : none;
  };
  const auto shown = [](const Value& v) {
    const std::string text = value_text(v);
    return text.empty() ? std::string("none") : text;
  };
  std::vector<std::string> parts;
  // Fields of an object that changed, as "prefix.key old -> new".
  std::function<void(const std::string&, const Value&, const Value&)> fields =
      [&](const std::string& prefix, const Value& old, const Value& now) {
        if (old.IsObject() && now.IsObject()) {
          for (const auto& m : now.GetObject())
            fields(prefix + "." + std::string(name_of(m)), get(old, name_of(m)), m.value);
          for (const auto& m : old.GetObject())
            if (!rsdiscovery::json::find(now, name_of(m)))
              fields(prefix + "." + std::string(name_of(m)), m.value, none);
          return;
        }
        if (old == now) return;
        const std::string name = prefix.substr(1);
        if (old.IsNull()) parts.push_back(name + " " + shown(now) + " (new)");
        else if (now.IsNull()) parts.push_back(name + " " + shown(old) + " (gone)");
        else parts.push_back(name + " " + shown(old) + " \u2192 " + shown(now));
      };
  const auto has = [](const Value& array, const Value& v) {
    return std::any_of(array.Begin(), array.End(), [&](const Value& e) { return e == v; });
  };
  for (const auto& m : after.GetObject()) {
    const std::string key(name_of(m));
    const Value& value = m.value;
    if (key == "first-seen" || key == "last-seen") continue;
    const auto& old = get(before, key);
    if (old == value) continue;
    if (key == "recovery" && value.IsBool()) {
      parts.push_back(value.GetBool() ? "entered recovery mode" : "left recovery mode");
    } else if (key == "server" && value.IsObject() && old.IsObject() &&
               get(old, "participant-guid") != get(value, "participant-guid")) {
      // Another server announces it now (the first one went, or a second one spoke last).
      std::string by = value_text(get(value, "participant-name"));
      if (by.empty()) by = value_text(get(value, "participant-guid"));
      const std::string at = value_text(get(value, "addresses"));
      parts.push_back("now served by " + by + (at.empty() ? "" : " (" + at + ")"));
    } else if (key == "in-use") {
      parts.push_back(in_use_change(old, value));
    } else if (key == "warnings" && value.IsArray()) {
      for (const auto& w : value.GetArray())
        if (!old.IsArray() || !has(old, w)) parts.push_back("warning: " + value_text(w));
      if (old.IsArray())
        for (const auto& w : old.GetArray())
          if (!has(value, w)) parts.push_back("warning gone: " + value_text(w));
    } else {
      fields("." + key, old, value);
    }
  }
  for (const auto& m : before.GetObject()) {
    const std::string key(name_of(m));
    if (!rsdiscovery::json::find(after, key) && key != "first-seen" && key != "last-seen") {
      if (key == "recovery") parts.push_back("left recovery mode");
      else if (key == "in-use") parts.push_back(in_use_change(m.value, none));
      else fields("." + key, m.value, none);
    }
  }
  return join(parts, ", ");
}

// `initial`: the event is one of --initial's listing of what is there at the start.
void print_event(const rsdiscovery::Event& e, bool json, bool initial, const std::string* before) {
  const auto& d = e.device;
  std::string line;
  if (json) {
    // Keys in byte order, as in all of rs-discover's JSON.
    line = "{\"device\":" + rsdiscovery::json::dump(rsdiscovery::json::parse_or_null(d.json)) +
           ",\"event\":" + rsdiscovery::json::quote(rsdiscovery::to_string(e.type)) +
           ",\"id\":" + std::to_string(e.id) + (initial ? ",\"initial\":true" : "") +
           ",\"synthetic\":" + (e.synthetic ? "true" : "false") + "}";
  } else {
    char type[16];
    std::snprintf(type, sizeof type, "%-7s", rsdiscovery::to_string(e.type));
    line = paint(clock_now(), color::dim) + " " + paint(type, event_color(e.type)) + " " + d.id + "  " +
           (d.name.empty() ? "-" : d.name);
    if (!d.serial.empty()) line += "  serial " + d.serial;
    if (d.domain) line += "  domain " + std::to_string(*d.domain);
    if (d.usb && !d.usb->port_path.empty()) line += "  usb " + d.usb->port_path;
    if (d.server && !d.server->addresses.empty()) line += "  " + device_addresses(d);
    if (const auto host = rsdiscovery::sharing_host(d))  // another host's USB camera: whose
      line += "  on " + (host->name.empty() ? std::string("?") : host->name) +
              (host->addresses.empty() ? "" : " (" + join(host->addresses, ",") + ")");
    if (d.recovery) line += "  " + paint("(recovery)", color::yellow);
    if (initial) line += "  " + paint("(present at start)", color::dim);
    else if (e.synthetic) line += "  " + paint("(re-listed)", color::dim);
    if (e.type == rsdiscovery::Event::Type::changed && before) {
      const std::string what = changes(*before, d.json);
      if (!what.empty()) line += "  " + paint(what, color::yellow);
    }
  }
  line += '\n';
  std::fputs(line.c_str(), stdout);
  std::fflush(stdout);
}

int run(const ParsedArgs& args) {
  if (!args.positional.empty()) throw UsageError("unexpected argument '" + args.positional[0] + "'");
  rsdiscovery::WatchOptions options;
  options.filter(filter_from(args));
  // Feedback on stderr while the daemon is away (stdout stays events only): one line
  // when it goes, one when it is back, however many attempts lie between; the first
  // connection is no news. Runs on the library's thread.
  std::atomic<bool> ever_lost{false};
  options.on_status([&ever_lost, lost = false,
                     since = std::chrono::steady_clock::time_point()](const rsdiscovery::WatchStatus& s) mutable {
    if (s.connected == !lost) return;  // no change: connected, or one more failed attempt
    lost = !s.connected;
    if (lost) {
      ever_lost = true;
      since = std::chrono::steady_clock::now();
      std::fprintf(stderr, "rs-discover: %s lost the daemon, reconnecting%s\n", clock_now().c_str(),
                   s.message.empty() ? "" : (" (" + s.message + ")").c_str());
    } else {
      const auto away = std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
      std::fprintf(stderr, "rs-discover: %s connected again after %.1f s%s\n", clock_now().c_str(), away,
                   s.message.empty() ? "" : (": " + s.message).c_str());
    }
  });
  options.initial(args.has("initial"));
  if (args.has("last-event-id")) {
    const std::string text = args.get("last-event-id");
    char* end = nullptr;
    unsigned long long v = std::strtoull(text.c_str(), &end, 10);
    if (text.empty() || *end) throw UsageError("--last-event-id wants a number, not '" + text + "'");
    options.last_event_id(v);
  }
  int count = args.get_int("count", 0, 0, 1000000000);
  bool has_timeout = args.has("timeout");
  double timeout = args.get_seconds("timeout", 0);
  bool json = args.has("json");

  // SIGINT/SIGTERM end the watch cleanly: a thread of ours takes them.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  auto client = make_client(args);
  rsdiscovery::Watch watch = client.watch(options);
  // The devices as last seen, so a `changed` line can say what changed: the watch's
  // own starting view, then every event.
  std::map<std::string, std::string> last;
  for (const auto& d : watch.devices()) last[d.id] = d.json;
  std::atomic<bool> interrupted{false}, finishing{false};
  std::thread signals([&] {
    int sig = 0;
    sigwait(&stop_signals, &sig);
    if (finishing) return;  // our own wake-up at the end
    interrupted = true;
    watch.stop();
  });
  struct Join {
    std::thread& t;
    std::atomic<bool>& finishing;
    ~Join() {
      finishing = true;
      pthread_kill(t.native_handle(), SIGTERM);
      t.join();
    }
  } join{signals, finishing};

  auto deadline = std::chrono::steady_clock::now() +
                  std::chrono::milliseconds(static_cast<long long>(timeout * 1000));
  int seen = 0;
  // --initial's listing: the synthetic events before the first one the daemon sent
  // and before any outage (a re-list after one is reported as "re-listed").
  bool listing = options.initial();
  while (count == 0 || seen < count) {
    std::optional<rsdiscovery::Event> e;
    if (has_timeout) {
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) break;
      e = watch.next(left);
      if (!e && !watch.stopped()) continue;  // timed out: the loop ends above
    } else {
      e = watch.next();
    }
    if (!e) break;  // stopped
    listing = listing && e->synthetic && !ever_lost;
    const auto it = last.find(e->device.id);
    print_event(*e, json, listing, it == last.end() ? nullptr : &it->second);
    if (e->type == rsdiscovery::Event::Type::removed) last.erase(e->device.id);
    else last[e->device.id] = e->device.json;
    ++seen;
  }
  watch.stop();
  if (interrupted) return kOk;
  if (count > 0 && seen < count) {
    std::fprintf(stderr, "rs-discover: timed out after %gs with %d of %d events\n", timeout, seen, count);
    return kNotFound;
  }
  return kOk;
}

}  // namespace

const Command kWatchCommand = {
    "watch",
    "print the changes as they happen",
    "watch [--json] [--initial] [-d N]... [-p LINE] [-s dds|usb|remote-usb] [--serial SERIAL] [-n TEXT]\n"
    "       [-a ADDR] [--host NAME] [--in-use | --free] [-c N] [-t S]",
    "Print one line per change of the device table (added, changed, removed) until interrupted,\n"
    "with the local date and time; a 'changed' line says what changed (fw-version 5.16.0.1 ->\n"
    "5.16.1.0, now served by NAME (ADDRESS), entered recovery mode). With --initial the\n"
    "cameras there at the start come first, marked 'present at start'. The stream resumes by\n"
    "itself when the daemon restarts (one line on stderr when it goes, one when it is back);\n"
    "what changed meanwhile is reported too (marked as re-listed).",
    with_device_filters({
        {"json", 'j', nullptr,
         "one JSON object a line: {\"event\", \"id\", \"synthetic\", \"device\"} (and \"initial\": true)"},
        {"initial", 'i', nullptr, "first report every device present now as added"},
        {"count", 'c', "N", "exit after N events"},
        {"timeout", 't', "S", "exit after S seconds (status 1 if --count events did not come)"},
        {"last-event-id", 0, "ID", "resume after this event id (from an earlier --json run)"},
    }),
    run,
};

}  // namespace rsdiscover
