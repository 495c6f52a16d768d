#include "service/service.hpp"

#include "config/config_keys.hpp"
#include "config/daemon_options.hpp"
#include "log/log.hpp"
#include "table/expected.hpp"

#include <algorithm>

namespace rsd::service {

namespace {

std::string join_ints(const std::vector<int>& v) {
  std::string out;
  for (int d : v) out += (out.empty() ? "" : ",") + std::to_string(d);
  return out;
}

std::string join(const std::vector<std::string>& v, const char* sep) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : sep) + s;
  return out;
}

}  // namespace

std::string status_text(std::string_view phase, std::size_t devices, const std::vector<int>& domains, bool usb,
                        std::string_view note) {
  std::string text;
  if (!phase.empty()) text += std::string(phase) + ": ";
  text += std::to_string(devices) + (devices == 1 ? " device" : " devices");
  if (!domains.empty()) text += (domains.size() == 1 ? " on DDS domain " : " on DDS domains ") + join_ints(domains);
  if (usb) text += domains.empty() ? " on USB" : " and USB";
  if (!note.empty()) text += "; " + std::string(note);
  return text;
}

std::string expected_text(const model::ExpectedReport& report) {
  if (report.expected() == 0) return "";
  std::string text = std::to_string(report.present.size()) + " of " + std::to_string(report.expected()) +
                     (report.expected() == 1 ? " expected camera" : " expected cameras");
  std::vector<std::string> missing;
  for (const auto& m : report.missing) missing.push_back(model::describe(m.camera));
  if (!missing.empty()) text += " (missing: " + join(missing, ", ") + ")";
  return text;
}

Service::Service(SharedTable& table, DomainSet& domains, UsbWatch& usb, ExpectedSet& expected, Config config,
                 std::vector<std::string> args)
    : table_(table), domains_(domains), usb_(usb), expected_(expected), config_(std::move(config)),
      args_(std::move(args)) {
  expected_.set(daemon_options(config_).expected);
  if (notifier_.active())
    log::debug("service: notifying the service manager" +
               (notifier_.watchdog() ? "; watchdog every " + std::to_string(notifier_.watchdog()->count()) + " us"
                                     : std::string()));
  change_hook_ = table_.add_change_hook([wake = &table_changed_] { wake->wake(); });
  count(Clock::now());
  last_status_ = current_status(false);
  notifier_.send("STATUS=" + last_status_);
}

Service::~Service() { table_.remove_change_hook(change_hook_); }

void Service::table_changed() { table_changed_.take(); }

void Service::api_listening() { api_up_ = true; }

bool Service::healthy(std::string* why) const {
  if (table_.closed()) {
    if (why) *why = "the device table is closed";
    return false;
  }
  for (const auto& d : domains_.status()) {
    if (d.state == DomainState::failed) {
      if (why) *why = "domain " + std::to_string(d.domain) + " failed: " + d.error;
      return false;
    }
  }
  return true;
}

void Service::count(Clock::time_point now) {
  const auto generation = table_.generation();
  if (generation == counted_generation_) return;
  const auto snap = table_.snapshot();
  device_count_ = snap.devices.size();
  expected_text_ = expected_text(expected_report(config_.expect, snap.devices, domains_.discovery_complete()));
  counted_generation_ = generation;
  next_count_ = now + kCountEvery;
}

std::string Service::current_status(bool ready) {
  std::string note = expected_text_;
  if (!note_.empty()) note += (note.empty() ? "" : "; ") + note_;
  std::string why;
  if (!healthy(&why)) note += (note.empty() ? "" : "; ") + why;
  // USB is named only while it is watched: not when off, nor when unavailable here.
  const auto usb = usb_.status();
  return status_text(ready ? "" : reloading_ ? "reloading" : "starting", device_count_, domains_.ids(),
                     usb && usb->watching(), note);
}

Service::Clock::duration Service::tick(Clock::time_point now) {
  // A burst of changes (a flood of cameras coming and going) is counted once per
  // kCountEvery, not once per change: the count reads the whole table.
  if (now >= next_count_) count(now);
  if (!ready_sent_ && api_up_ && domains_.all_reading()) {
    ready_sent_ = true;
    count(now);
    last_status_ = current_status(true);
    notifier_.send("READY=1\nSTATUS=" + last_status_);
    // The count is the table's only once every domain's first discovery is over (a
    // camera already serving arrives after it): until then the log says it is not.
    done_word_ = reloading_ ? "reloaded: " : "ready: ";
    if (!domains_.discovery_complete())
      log::notice(std::string(reloading_ ? "reloaded" : "listening") + "; discovery in progress on DDS domain" +
                  (domains_.ids().size() == 1 ? " " : "s ") + join_ints(domains_.ids()));
    reloading_ = false;
  } else {
    const std::string status = current_status(ready_sent_);
    if (status != last_status_) {
      last_status_ = status;
      notifier_.send("STATUS=" + status);
    }
  }
  if (!done_word_.empty() && ready_sent_ && domains_.discovery_complete()) {
    count(now);
    log::notice(done_word_ + current_status(true));
    done_word_.clear();
  }

  // Nothing to do until the table changes (its hook wakes the main loop through
  // fd()), a count held back is due, or the watchdog is.
  Clock::duration wait = std::chrono::hours(1);
  if (table_.generation() != counted_generation_) wait = std::max(Clock::duration::zero(), next_count_ - now);
  if (!done_word_.empty()) wait = std::chrono::milliseconds(100);  // the log line follows completion closely
  if (const auto interval = notifier_.watchdog()) {
    if (now >= next_watchdog_) {
      // Every half interval, as sd_watchdog_enabled(3) advises; the main loop
      // being here at all is half of the health check.
      std::string why;
      if (healthy(&why)) {
        notifier_.send("WATCHDOG=1");
        unhealthy_logged_ = false;
      } else if (!unhealthy_logged_) {
        log::error("service: unhealthy, no longer feeding the watchdog: " + why);
        unhealthy_logged_ = true;
      }
      next_watchdog_ = now + std::chrono::duration_cast<Clock::duration>(*interval / 2);
    }
    wait = std::min(wait, next_watchdog_ - now);
  }
  return wait;
}

void Service::reload() {
  notifier_.send(reloading_message() + "\nSTATUS=reloading the configuration");
  reloading_ = true;
  ready_sent_ = false;  // READY=1 again once every domain of the new set reads
  log::notice("reloading the configuration" +
              (config_.config_file.empty() ? std::string() : " from " + config_.config_file));

  std::vector<const char*> argv;
  for (const auto& a : args_) argv.push_back(a.c_str());
  CommandLine cl;
  try {
    cl = parse_command_line(static_cast<int>(argv.size()), argv.data());
  } catch (const ConfigError& e) {
    note_ = std::string("reload failed, still running the previous configuration: ") + e.what();
    log::error(note_);
    // Nothing changed: ready again at once, and no "reloaded" line for what was not.
    reloading_ = false;
    ready_sent_ = true;
    count(Clock::now());
    last_status_ = current_status(true);
    notifier_.send("READY=1\nSTATUS=" + last_status_);
    return;
  }
  const Config& next = cl.config;
  // The live part of the options (daemon_options, as main() made the parts).
  const DaemonOptions running = daemon_options(config_), options = daemon_options(next);

  log::set_level(options.log_level);
  if (network_ && (options.interfaces.include != running.interfaces.include ||
                   options.interfaces.exclude != running.interfaces.exclude))
    network_->apply(options.interfaces, std::chrono::steady_clock::now());
  const auto& caps = options.session.book;
  const bool caps_changed = caps.max_devices_per_participant != running.session.book.max_devices_per_participant ||
                            caps.max_devices_per_domain != running.session.book.max_devices_per_domain;
  if (caps_changed) domains_.set_device_caps(caps.max_devices_per_participant, caps.max_devices_per_domain);
  const auto change = domains_.apply(options.domains);

  // What listeners and DDS participants were made with waits for a restart; the
  // key table (config_keys) says which keys those are.
  const auto restart_only = restart_only_changes(config_, next);
  if (!restart_only.empty())
    log::warning("reload: " + join(restart_only, ", ") + " changed; that takes effect on restart");
  // The running configuration takes the next one's live keys, the domains as joined.
  for (const auto& key : config_keys())
    if (key.reload == Reload::live) key.copy(next, config_);
  config_.domains = domains_.ids();
  config_.config_file = next.config_file;
  expected_.set(options.expected);
  counted_generation_ = ~std::uint64_t{0};  // STATUS= counts the new list

  note_ = change.failed.empty() ? "" : "reload could not join " + join(change.failed, "; ");
  std::vector<std::string> what;
  // USB on or off, live: off takes the USB devices out of the table.
  if (usb_.apply(options.usb)) what.push_back(options.usb ? "USB watched" : "USB no longer watched");
  if (caps_changed)
    what.push_back("device caps now " + std::to_string(caps.max_devices_per_participant) + " per participant, " +
                   std::to_string(caps.max_devices_per_domain) + " per domain");
  if (!change.joined.empty()) {
    std::vector<std::string> j;
    for (int d : change.joined) j.push_back(std::to_string(d));
    what.push_back("joined domain(s) " + join(j, ","));
  }
  if (!change.left.empty()) {
    std::vector<std::string> l;
    for (int d : change.left) l.push_back(std::to_string(d));
    what.push_back("left domain(s) " + join(l, ","));
  }
  log::notice("reload applied: " + (what.empty() ? std::string("no source changes") : join(what, ", ")) +
              "; domains now " + join_ints(config_.domains));
}

void Service::stopping() {
  notifier_.send("STOPPING=1\nSTATUS=stopping");
}

}  // namespace rsd::service
