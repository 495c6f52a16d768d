// The daemon's side of the service-manager contract: READY=1 once every domain
// reads and the API listens, STATUS= kept current, WATCHDOG=1 while healthy,
// RELOADING=1/READY=1 around a configuration reload, STOPPING=1 at the end.
// main.cpp calls these from its event loop; nothing here runs a thread.
#pragma once

#include "config/config.hpp"
#include "service/domain_set.hpp"
#include "service/expected_set.hpp"
#include "service/network_watch.hpp"
#include "service/notifier.hpp"
#include "service/usb_watch.hpp"
#include "service/wake_fd.hpp"
#include "table/shared_table.hpp"

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace rsd::service {

// STATUS= text, e.g. "3 devices on DDS domains 0,5 and USB", with the phase
// ("starting: ...") before it when not ready and `note` after it. `usb` is
// whether local USB is being watched (configured and available).
std::string status_text(std::string_view phase, std::size_t devices, const std::vector<int>& domains, bool usb,
                        std::string_view note);

// STATUS='s part for the expected cameras: "2 of 3 expected cameras (missing: wrist
// (123456))"; "" when none are expected.
std::string expected_text(const model::ExpectedReport& report);

class Service {
 public:
  using Clock = std::chrono::steady_clock;

  // `args` is the command line the daemon started with: a reload parses it
  // again, so flags keep winning over the re-read config file.
  // `expected` is set from the configuration here and on every reload.
  Service(SharedTable& table, DomainSet& domains, UsbWatch& usb, ExpectedSet& expected, Config config,
          std::vector<std::string> args);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  // Readable when the table changed since table_changed(): the main loop polls it
  // and then calls tick(), which keeps STATUS= current without a clock.
  int fd() const { return table_changed_.fd(); }
  void table_changed();

  void api_listening();  // the last READY=1 condition besides the domains
  // SIGHUP: re-reads the configuration and applies what can change live (the
  // domains, USB on or off, the log level). An invalid configuration keeps the
  // running one and says why, in the log and in STATUS=.
  void reload();
  void stopping();  // STOPPING=1

  // Sends what is due (READY=1, STATUS=, WATCHDOG=1); returns how soon it wants
  // to be called again.
  Clock::duration tick(Clock::time_point now);

  bool ready() const { return ready_sent_; }
  bool healthy(std::string* why = nullptr) const;
  const Config& config() const { return config_; }
  // The network follower a reload gives the interface rules to (none: not followed).
  void set_network(NetworkWatch* network) { network_ = network; }

 private:
  // STATUS= keeps up with the table at most this often.
  static constexpr Clock::duration kCountEvery = std::chrono::seconds(1);

  void count(Clock::time_point now);  // the table's device count and expected cameras, if it changed
  std::string current_status(bool ready);

  SharedTable& table_;
  WakeFd table_changed_;
  SharedTable::HookId change_hook_ = 0;
  DomainSet& domains_;
  UsbWatch& usb_;
  ExpectedSet& expected_;
  NetworkWatch* network_ = nullptr;
  Config config_;
  std::vector<std::string> args_;
  Notifier notifier_;

  bool api_up_ = false;
  bool ready_sent_ = false;  // false at start and during a reload: READY=1 is owed
  bool reloading_ = false;
  std::string note_;         // what went wrong in the last reload; "" when it all took
  std::string done_word_;    // "ready: " or "reloaded: ", logged once discovery completes; "" when said
  std::string last_status_;
  std::uint64_t counted_generation_ = ~std::uint64_t{0};
  std::size_t device_count_ = 0;
  std::string expected_text_;  // of counted_generation_
  Clock::time_point next_count_{};  // a change before this is counted then
  Clock::time_point next_watchdog_{};
  bool unhealthy_logged_ = false;
};

}  // namespace rsd::service
