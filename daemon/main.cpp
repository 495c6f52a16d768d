// rs-discoveryd: flags and config -> wiring -> signal and timer loop. Nothing else.
#include "api/api_server.hpp"
#include "config/config.hpp"
#include "config/config_check.hpp"
#include "config/daemon_options.hpp"
#include "log/log.hpp"
#include "service/domain_set.hpp"
#include "service/listen_sockets.hpp"
#include "service/network_watch.hpp"
#include "service/service.hpp"
#include "service/domains_and_usb_status.hpp"
#include "service/usb_watch.hpp"
#include "table/shared_table.hpp"

#include <malloc.h>
#include <poll.h>
#include <sys/stat.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

// Signals are taken synchronously through a signalfd. They are blocked before
// any thread exists, so DDS's and libusb's threads inherit the mask and never
// run a handler.
int block_signals() {
  sigset_t set;
  sigemptyset(&set);
  for (int s : {SIGTERM, SIGINT, SIGHUP, SIGUSR1}) sigaddset(&set, s);
  sigprocmask(SIG_BLOCK, &set, nullptr);
  signal(SIGPIPE, SIG_IGN);  // a client hanging up mid-reply is not our death
  return signalfd(-1, &set, SFD_CLOEXEC);
}

std::uint64_t first_generation() {
  // Event ids continue above any earlier run's, so a client resuming with an
  // id from before a restart is told to re-list rather than handed wrong events.
  using namespace std::chrono;
  return static_cast<std::uint64_t>(
      duration_cast<microseconds>(system_clock::now().time_since_epoch()).count());
}

// The default socket lives in a directory of its own (/run/rs-discoveryd) that
// systemd makes for the service; started by hand, the daemon makes it itself.
void make_socket_directory(const std::string& socket_path) {
  const auto slash = socket_path.rfind('/');
  if (slash == std::string::npos || slash == 0) return;
  const std::string dir = socket_path.substr(0, slash);
  if (mkdir(dir.c_str(), 0755) == 0) rsd::log::info("created " + dir);
}

}  // namespace

int main(int argc, char** argv) {
  // Two malloc arenas, not glibc's 8 per core: the API's worker threads each
  // took one, and what a burst left in them outlived every trim (RSS stayed well
  // above its start after a flood with clients asking; bench/flood.py).
  mallopt(M_ARENA_MAX, 2);
  rsd::CommandLine cl;
  // --check-config: an invalid configuration is its answer (exit 1, at its line and
  // column), not a usage error.
  const bool checking = std::any_of(argv + 1, argv + argc, [](const char* a) {
    const std::string_view arg(a);
    return arg == "--check-config" || arg.starts_with("--check-config=");
  });
  try {
    cl = rsd::parse_command_line(argc, argv);
  } catch (const rsd::ConfigError& e) {
    // At its line and column either way: a start under systemd says it as clearly
    // as --check-config would (the unit runs no ExecStartPre= check for it).
    std::fprintf(stderr, "rs-discoveryd: %s\n", rsd::locate_config_error(e.what()).c_str());
    return checking ? 1 : 2;
  }
  if (cl.action == rsd::CommandAction::check_config) {
    const rsd::Config& c = cl.config;
    std::string domains;
    for (int d : c.domains) domains += (domains.empty() ? "" : ",") + std::to_string(d);
    std::printf("rs-discoveryd: %s is valid: domains %s, socket %s, http %s, usb %s\n",
                c.config_file.empty() ? "the configuration (no file, the defaults)" : c.config_file.c_str(),
                domains.c_str(), c.socket_path.empty() ? "off" : c.socket_path.c_str(),
                c.http_host.empty() ? "off" : (c.http_host + ":" + std::to_string(c.http_port)).c_str(),
                c.usb ? "on" : "off");
    return 0;
  }
  if (cl.action == rsd::CommandAction::help) {
    std::fputs(rsd::usage_text(), stdout);
    return 0;
  }
  if (cl.action == rsd::CommandAction::version) {
    std::printf("rs-discoveryd %s\n", RSD_VERSION);
    return 0;
  }
  const rsd::Config& config = cl.config;
  const rsd::DaemonOptions options = rsd::daemon_options(config);
  rsd::log::set_level(options.log_level);

  const int signal_fd = block_signals();
  if (signal_fd < 0) {
    rsd::log::error("cannot create signalfd");
    return 1;
  }

  rsd::SharedTable table(4096, first_generation());
  rsd::service::DomainSet domains(table, options.session);
  rsd::service::NetworkWatch network(domains, options.interfaces, !options.session.interfaces_from_cyclone_config);
  try {
    domains.start(options.domains);
  } catch (const std::exception& e) {
    rsd::log::error(e.what());
    return 1;
  }
  // Local cameras, listed before the API opens; without USB access the source
  // logs why and DDS carries on.
  rsd::service::UsbWatch usb(table);
  usb.apply(options.usb);
  rsd::service::ExpectedSet expected;
  rsd::service::Service service(table, domains, usb, expected, config, std::vector<std::string>(argv, argv + argc));
  service.set_network(&network);

  const rsd::service::DomainsAndUsbStatus status(domains, usb, expected, options.session.describe_timeout);
  rsd::api::ApiServer api(table, status, RSD_VERSION);
  rsd::api::ApiOptions api_options = options.api;
  try {
    // Socket activation: systemd's sockets take the place of the configured ones.
    const auto passed = rsd::service::take_listen_sockets();
    for (const auto& note : passed.notes) rsd::log::info(note);
    api_options.inherited_unix_fd = passed.unix_fd;
    api_options.inherited_http_fd = passed.http_fd;
    if (passed.unix_fd < 0 && !api_options.unix_socket.empty()) make_socket_directory(api_options.unix_socket);
    api.start(api_options);
  } catch (const std::exception& e) {
    rsd::log::error(e.what());
    return 1;
  }
  service.api_listening();
  const std::string on_unix = api_options.inherited_unix_fd >= 0 ? "the Unix socket from systemd"
                              : api_options.unix_socket.empty()  ? ""
                                                                 : "unix:" + api_options.unix_socket;
  const std::string on_http = api_options.inherited_http_fd >= 0 ? "the HTTP socket from systemd"
                              : api_options.http_host.empty()
                                  ? ""
                                  : "http://" + api_options.http_host + ":" + std::to_string(api.http_port());
  rsd::log::notice(std::string("rs-discoveryd ") + RSD_VERSION + " serving" +
                   (on_unix.empty() ? "" : " on " + on_unix) +
                   (on_http.empty() ? "" : (on_unix.empty() ? " on " : " and on ") + on_http));

  // glibc keeps what a burst freed (cameras come and gone, a large table emptied)
  // in its arenas until asked for it: its free pages are handed back once the burst
  // is over, kTrimAfter after the last change to the table or wake-up from DDS (a
  // peer's departure frees more after the table has changed), and on a network that
  // never quietens down kTrimAtMost after the burst began. Not on a clock: an idle
  // daemon is not woken for it.
  constexpr auto kTrimAfter = std::chrono::seconds(2);
  constexpr auto kTrimAtMost = std::chrono::seconds(10);
  auto trim_at = Clock::time_point::max();
  auto burst_began = Clock::time_point::max();
  const auto trim_after_burst = [&] {
    const auto now = Clock::now();
    if (burst_began == Clock::time_point::max()) burst_began = now;
    trim_at = std::min(now + kTrimAfter, burst_began + kTrimAtMost);
  };

  bool running = true;
  bool usb_changed = true;  // the cameras listed at start, shared once the loop runs
  while (running) {
    const auto now = Clock::now();
    if (now >= trim_at) {
      malloc_trim(0);
      trim_at = burst_began = Clock::time_point::max();
    }
    // This host's cameras, announced to other hosts as soon as they change: the
    // USB source wakes the loop through usb.fd().
    if (usb_changed && options.session.share.share) domains.share_usb(usb.cameras());
    usb_changed = false;
    // Each part says when it next has something to do; the loop sleeps until the
    // soonest of those, or until a descriptor wakes it.
    const auto wait = std::chrono::ceil<std::chrono::milliseconds>(std::min(
        {domains.tick(now), network.tick(now), service.tick(now), Clock::duration(trim_at - now)}));
    // fd -1: not polled
    pollfd pfds[5] = {{signal_fd, POLLIN, 0},
                      {network.fd(), POLLIN, 0},
                      {usb.fd(), POLLIN, 0},
                      {domains.fd(), POLLIN, 0},
                      {service.fd(), POLLIN, 0}};
    const int timeout = static_cast<int>(std::max<std::int64_t>(wait.count(), 1));
    if (poll(pfds, 5, timeout) <= 0) continue;
    if (pfds[1].revents & POLLIN) network.readable(Clock::now());
    if (pfds[2].revents & POLLIN) usb_changed = usb.changed();
    if (pfds[3].revents & POLLIN) {
      domains.woken();  // the sessions tick at the next turn
      trim_after_burst();
    }
    if (pfds[4].revents & POLLIN) {
      service.table_changed();  // STATUS= at the next turn
      trim_after_burst();
    }
    if (!(pfds[0].revents & POLLIN)) continue;
    signalfd_siginfo si{};
    if (read(signal_fd, &si, sizeof si) != static_cast<ssize_t>(sizeof si)) continue;
    switch (si.ssi_signo) {
      case SIGTERM:
      case SIGINT:
        rsd::log::notice("stopping on signal " + std::to_string(si.ssi_signo));
        service.stopping();
        running = false;
        break;
      case SIGHUP:
        service.reload();
        break;
      case SIGUSR1:
        domains.rebuild();
        break;
      default:
        break;
    }
  }

  // Streams first (they wait on the table), then listeners, then DDS.
  table.close();
  api.stop();
  usb.stop();
  domains.stop();
  close(signal_fd);
  return 0;
}
