// The real ApiServer over a table the test drives through stdin, with no DDS.
// It reaches what the daemon cannot be made to do on cue: a change log that
// overflows (resync), dozens of devices, devices with odd fields, the stream limit,
// a first discovery that never ends, streams dropped while the table lives on. The
// client library's unit tests (tests/client) run against it too.
//
//   api_harness --routes   (prints the route table, "METHOD PATTERN [blocking]" a line)
//   api_harness [--socket PATH] [--http HOST:PORT] [--keepalive-ms N]
//               [--max-streams N] [--log-capacity N] [--first-generation N]
//               [--max-connections N] [--client-timeout-ms N] [--idle-timeout-ms N]
//               [--stream-buffer-limit BYTES] [--allowed-host NAME]...
//               [--domains [DomainStatus json...]]
// stdout: "ready http_port=N" once serving; stdin lines:
//   upsert ID {json}   remove ID   domains [DomainStatus json...]   stop
//   api-stop   api-start
// (a domain's "complete" is true unless the line says otherwise; --domains sets them
// before the first request, as a daemon starts with its first discovery running).
// api-stop stops the ApiServer (every stream ends, the socket goes) while the table
// lives on; api-start serves it again, on the same socket and port, from a new
// ApiServer: clients see their streams dropped and can resume from the change log.
// Each command is acknowledged with "ok <generation>".
#include "api/api_server.hpp"
#include "api/routes.hpp"
#include "log/log.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>

namespace {

// The sources' status as the test sets it: domains from stdin, no USB, nothing to describe.
class HarnessStatus final : public rsd::StatusView {
 public:
  void set_domains(std::vector<rsd::DomainStatus> next) {
    std::lock_guard lock(mutex_);
    domains_ = std::move(next);
  }
  std::vector<rsd::DomainStatus> domains() const override {
    std::lock_guard lock(mutex_);
    return domains_;
  }
  std::vector<rsd::model::Participant> participants() const override { return {}; }
  std::optional<rsd::UsbStatus> usb() const override { return std::nullopt; }
  rsd::DeviceDescription describe(const std::string&) const override {
    return {rsd::DeviceDescription::Outcome::not_found, {}, "the harness describes no devices"};
  }

 private:
  mutable std::mutex mutex_;
  std::vector<rsd::DomainStatus> domains_;
};

// `text`: a JSON array of DomainStatus documents; unknown states throw.
std::vector<rsd::DomainStatus> parse_domains(const std::string& text) {
  std::vector<rsd::DomainStatus> out;
  for (const auto& d : nlohmann::json::parse(text)) {
    rsd::DomainStatus s;
    s.domain = d.value("domain", 0);
    s.state = rsd::parse_domain_state(d.value("state", "running")).value();
    s.participant_guid = d.value("participant-guid", "");
    s.accepted = d.value("accepted", 0u);
    s.rejected = d.value("rejected", std::map<std::string, std::uint64_t>{});
    s.complete = d.value("complete", true);
    out.push_back(s);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--routes") {  // for test_routes_spec.py
    for (const auto& route : rsd::api::routes())
      std::cout << route.method << ' ' << route.pattern << (route.blocking ? " blocking" : "") << '\n';
    return 0;
  }
  rsd::api::ApiOptions options;
  std::size_t log_capacity = 4096;
  std::uint64_t first_generation = 0;
  HarnessStatus sources;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--socket") {
      options.unix_socket = value;
    } else if (flag == "--http") {
      const auto colon = value.rfind(':');
      options.http_host = value.substr(0, colon);
      options.http_port = std::stoi(value.substr(colon + 1));
    } else if (flag == "--keepalive-ms") {
      options.keepalive_ms = std::stoi(value);
    } else if (flag == "--max-streams") {
      options.max_event_streams = std::stoul(value);
    } else if (flag == "--max-connections") {
      options.max_connections = std::stoul(value);
    } else if (flag == "--client-timeout-ms") {
      options.client_timeout_ms = std::stoi(value);
    } else if (flag == "--idle-timeout-ms") {
      options.idle_timeout_ms = std::stoi(value);
    } else if (flag == "--stream-buffer-limit") {
      options.stream_buffer_limit = std::stoul(value);
    } else if (flag == "--allowed-host") {
      options.allowed_hosts.push_back(value);
    } else if (flag == "--log-capacity") {
      log_capacity = std::stoul(value);
    } else if (flag == "--first-generation") {
      first_generation = std::stoull(value);
    } else if (flag == "--domains") {
      sources.set_domains(parse_domains(value));
    } else {
      std::cerr << "unknown flag " << flag << "\n";
      return 2;
    }
  }
  rsd::log::set_level(rsd::log::Level::debug);

  rsd::SharedTable table(log_capacity, first_generation);
  auto server = std::make_unique<rsd::api::ApiServer>(table, sources, "0.0.0-harness");
  try {
    server->start(options);
  } catch (const std::exception& e) {
    std::cout << "error " << e.what() << std::endl;
    return 1;
  }
  // A restarted ApiServer binds the port this one got, where clients look for it.
  if (!options.http_host.empty()) options.http_port = server->http_port();
  std::cout << "ready http_port=" << server->http_port() << std::endl;

  std::string line;
  while (std::getline(std::cin, line)) {
    const auto sp = line.find(' ');
    const std::string cmd = line.substr(0, sp), rest = sp == std::string::npos ? "" : line.substr(sp + 1);
    try {
      if (cmd == "upsert") {
        const auto sp2 = rest.find(' ');
        table.upsert(rest.substr(0, sp2), nlohmann::json::parse(rest.substr(sp2 + 1)));
      } else if (cmd == "remove") {  // remove ID [REASON], as the model spells it (default: stopping)
        const auto sp2 = rest.find(' ');
        const auto reason =
            sp2 == std::string::npos ? rsd::model::RemovalReason::stopping
                                     : rsd::model::parse_removal_reason(rest.substr(sp2 + 1)).value();
        table.remove(rest.substr(0, sp2), reason);
      } else if (cmd == "domains") {
        sources.set_domains(parse_domains(rest));  // an unknown state: an error line
      } else if (cmd == "api-stop") {
        if (server) server->stop();
        server.reset();
      } else if (cmd == "api-start") {
        if (!server) {
          auto next = std::make_unique<rsd::api::ApiServer>(table, sources, "0.0.0-harness");
          next->start(options);  // throws: an error line, and still stopped
          server = std::move(next);
        }
      } else if (cmd == "stop") {
        break;
      }
      std::cout << "ok " << table.generation() << std::endl;
    } catch (const std::exception& e) {
      std::cout << "error " << e.what() << std::endl;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  if (server) server->stop();
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0);
  std::cout << "stopped ms=" << ms.count() << std::endl;
  return 0;
}
