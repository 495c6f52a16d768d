// The parts of `rs-discover doctor`, shared by its files: the report the checks add
// findings to (doctor_report.cpp), this host's network as the checks read it
// (doctor_host.cpp), the checks of what the daemon and this host report
// (doctor_checks.cpp), and the advice when the daemon cannot be asked
// (doctor_unreachable.cpp). cmd_doctor.cpp runs them in order.
#pragma once

#include "common.hpp"
#include "spdp.hpp"

#include <netinet/in.h>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rsdiscover::doctor {

// Verdicts: `warn` and `fail` are findings that explain a missing camera (exit 1);
// `info` ones are worth knowing but explain none, so a healthy network, however busy,
// exits 0. A finding about a participant holds for the participant, not for each of
// its addresses: a server on two networks is on both.
enum class Verdict { ok, info, warn, fail };

struct Finding {
  Verdict verdict;
  std::string topic;
  std::string text;
};

// The findings in the order found; print() writes them (lines, or --json) and
// returns the exit status they stand for.
class Report {
 public:
  void add(Verdict v, std::string topic, std::string text) { findings_.push_back({v, std::move(topic), std::move(text)}); }
  int print(bool json) const;

 private:
  std::vector<Finding> findings_;
};

// A JSON file a user edited, as its readers take it: librealsense's parser and the
// daemon's skip the UTF-8 byte order mark some editors put first; RapidJSON does not.
inline std::string_view without_bom(std::string_view text) {
  return text.substr(text.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0);
}

// ---- this host's network (doctor_host.cpp) ------------------------------------------

struct Interface {
  std::string name;
  in_addr address{};
  in_addr netmask{};
  bool up = false, multicast = false, loopback = false;
};

std::vector<Interface> ipv4_interfaces();
std::string text_of(in_addr a);
std::optional<in_addr> ipv4(const std::string& text);
bool same_subnet(const Interface& itf, in_addr other);
std::string multicast_route();  // the interface discovery multicast leaves by; "" when none
bool link_local(in_addr a);
bool container_bridge(in_addr a);
bool endpoint_is_local(const std::string& endpoint);  // a Unix socket or a loopback address

// ---- the checks (doctor_checks.cpp) -------------------------------------------------

// The expected cameras not listed, first of all (doctor_expected.cpp); nothing for a
// daemon that has no /v1/expected.
void check_expected(Report& r, const std::optional<rsdiscovery::Expected>& expected);

void check_domains(Report& r, const std::vector<rsdiscovery::DomainStatus>& domains);
void check_other_domains(Report& r, const std::vector<rsdiscovery::DomainStatus>& domains,
                         const std::optional<spdp::Heard>& heard, double listened_s);
void check_participants(Report& r, const std::vector<rsdiscovery::Participant>& all,
                        const std::vector<rsdiscovery::DomainStatus>& domains);
void check_host_network(Report& r, const std::vector<rsdiscovery::Participant>& all);
void check_networks(Report& r, const std::vector<rsdiscovery::DomainStatus>& domains,
                    const std::optional<spdp::Heard>& heard);
void check_devices(Report& r, const std::vector<rsdiscovery::Device>& devices, const rsdiscovery::Health& health);
void check_http(Report& r, const rsdiscovery::Health& health);
// Cameras that left and cameras that flap, from GET /v1/history (doctor_history.cpp).
void check_history(Report& r, const std::string& history_json);
// Which hosts share USB cameras with the daemon, and which daemons it hears share none
// (doctor_sharing.cpp).
void check_sharing(Report& r, const std::vector<rsdiscovery::Device>& devices,
                   const std::vector<rsdiscovery::Participant>& participants,
                   const std::vector<rsdiscovery::DomainStatus>& domains);

// What the librealsense of the user running this (and under sudo of the invoking user
// and root) will see of the network cameras listed, and the fix for it
// (doctor_librealsense.cpp). fix_librealsense returns an exit status.
void check_librealsense(Report& r, const std::vector<rsdiscovery::Device>& devices,
                        const std::vector<rsdiscovery::DomainStatus>& domains);
int fix_librealsense(const std::vector<rsdiscovery::Device>& devices,
                     const std::vector<rsdiscovery::DomainStatus>& domains);

// The camera `id` names (doctor ID; doctor_camera.cpp): listed or why not, and who uses
// it (its DDS clients and what they stream; the processes holding a USB camera).
void check_camera(Report& r, rsdiscovery::Client& client, const std::string& id);

// ---- when the daemon cannot be asked (doctor_unreachable.cpp) -----------------------

// What to do about `e`, by its cause; "" when there is nothing to add.
std::string unreachable_hint(const rsdiscovery::Error& e, const rsdiscovery::Endpoint& endpoint);

}  // namespace rsdiscover::doctor
