// Which interfaces the domains join, and when the daemon joins them anew as the
// host's network changes (issue 21): the pure parts, driven with made-up
// interface lists and times, as LostServers' tests drive it. The kernel's side
// (rtnetlink, namespaces) is tests/interop/test_network_follow.py.
#include "net/interfaces.hpp"
#include "net/network_follower.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

using namespace std::chrono_literals;
using rsd::net::InterfaceRules;
using rsd::net::NetInterface;
using rsd::net::NetworkFollower;

namespace {

const NetworkFollower::Clock::time_point t0{};

NetInterface eth(const std::string& name, std::vector<std::string> ipv4, bool up = true) {
  NetInterface i;
  i.name = name;
  i.up = i.running = up;
  i.multicast = true;
  i.ipv4 = std::move(ipv4);
  return i;
}

NetInterface loopback() {
  NetInterface i = eth("lo", {"127.0.0.1"});
  i.loopback = true;
  i.multicast = false;
  return i;
}

std::vector<std::string> names(const std::vector<NetInterface>& list) {
  std::vector<std::string> out;
  for (const auto& i : list) out.push_back(i.name);
  return out;
}

const InterfaceRules kDefaults{{}, rsd::net::default_excluded_interfaces()};

}  // namespace

TEST(SelectInterfaces, EveryUsableOneButLoopbackAndBridges) {
  auto down = eth("eth2", {"10.2.0.1"}, false);
  auto no_carrier = eth("eth3", {"10.3.0.1"});
  no_carrier.running = false;
  auto no_multicast = eth("tun0", {"10.8.0.1"});
  no_multicast.multicast = false;
  const std::vector<NetInterface> all{loopback(), eth("wlan0", {"192.168.1.5"}), eth("eth1", {"10.1.0.1"}), down,
                                      no_carrier, no_multicast, eth("eth4", {}), eth("docker0", {"172.17.0.1"}),
                                      eth("veth1a2b", {"169.254.3.3"}), eth("virbr0", {"192.168.122.1"})};
  EXPECT_EQ(names(select_interfaces(all, kDefaults)), (std::vector<std::string>{"eth1", "wlan0"}));
  // Nothing usable: loopback, so local peers still meet.
  EXPECT_EQ(names(select_interfaces({loopback(), down}, kDefaults)), (std::vector<std::string>{"lo"}));
}

TEST(SelectInterfaces, AnExplicitListWinsOverTheExclusions) {
  const std::vector<NetInterface> all{loopback(), eth("eth0", {"10.0.0.1"}), eth("enp3s0", {"10.3.0.1"}),
                                      eth("enp4s0", {"10.4.0.1"}), eth("docker0", {"172.17.0.1"})};
  EXPECT_EQ(names(select_interfaces(all, {{"enp*"}, kDefaults.exclude})), (std::vector<std::string>{"enp3s0", "enp4s0"}));
  EXPECT_EQ(names(select_interfaces(all, {{"docker0", "lo"}, kDefaults.exclude})),
            (std::vector<std::string>{"docker0", "lo"}));
  // Named but not there yet (the adapter is not plugged in): loopback until it is,
  // never an interface the user did not name.
  EXPECT_EQ(names(select_interfaces(all, {{"eth9"}, kDefaults.exclude})), (std::vector<std::string>{"lo"}));
  EXPECT_EQ(names(select_interfaces(all, {{}, {}})), (std::vector<std::string>{"docker0", "enp3s0", "enp4s0", "eth0"}));
}

TEST(CycloneInterfaces, XmlNamesEachAndAnExplicitConfigIsSeen) {
  EXPECT_EQ(rsd::net::cyclone_interfaces_xml({}), "");
  EXPECT_EQ(rsd::net::cyclone_interfaces_xml({eth("eth0", {"1.2.3.4"}), eth("eth1", {})}),
            "<General><Interfaces><NetworkInterface name=\"eth0\"/><NetworkInterface name=\"eth1\"/>"
            "</Interfaces></General>");
  EXPECT_FALSE(rsd::net::cyclone_config_names_interfaces(""));
  EXPECT_FALSE(rsd::net::cyclone_config_names_interfaces("<Discovery><ParticipantIndex>auto</ParticipantIndex></Discovery>"));
  EXPECT_TRUE(rsd::net::cyclone_config_names_interfaces(
      "<General><Interfaces><NetworkInterface name=\"eth1\"/></Interfaces></General>"));
  EXPECT_TRUE(rsd::net::cyclone_config_names_interfaces("<General><NetworkInterfaceAddress>eth1</NetworkInterfaceAddress></General>"));
  const std::string path = ::testing::TempDir() + "/rsd-cyclone-interfaces.xml";
  std::ofstream(path) << "<CycloneDDS><Domain><General><Interfaces><NetworkInterface name=\"eth1\"/>"
                         "</Interfaces></General></Domain></CycloneDDS>";
  EXPECT_TRUE(rsd::net::cyclone_config_names_interfaces("<Tracing/>,file://" + path));
  // Cyclone takes a bare path too (measured: `--cyclonedds-config /etc/x.xml`
  // naming NetworkInterfaceAddress was combined with the daemon's own list, and
  // Cyclone refused the mix, so the domain was never made).
  EXPECT_TRUE(rsd::net::cyclone_config_names_interfaces(path));
  EXPECT_TRUE(rsd::net::cyclone_config_names_interfaces(" " + path + " ,<Tracing/>"));
  EXPECT_FALSE(rsd::net::cyclone_config_names_interfaces("file:///nonexistent/cyclone.xml"));
  std::remove(path.c_str());
}

TEST(NetworkFollower, ABurstCostsOneRefreshAfterItSettles) {
  NetworkFollower f({});  // started before the network had an address
  EXPECT_FALSE(f.wait(t0));
  f.changed({}, t0);                              // the link comes up: nothing usable yet
  f.changed({eth("eth0", {"10.0.0.5"})}, t0 + 50ms);  // the DHCP lease
  f.changed({eth("eth0", {"10.0.0.5"})}, t0 + 80ms);  // a route
  EXPECT_FALSE(f.due(t0 + 300ms));  // still settling (300 ms after the last)
  EXPECT_EQ(*f.wait(t0 + 300ms), 80ms);
  const auto chosen = f.due(t0 + 380ms);
  ASSERT_TRUE(chosen);
  EXPECT_EQ(names(*chosen), (std::vector<std::string>{"eth0"}));
  EXPECT_EQ(f.refreshes(), 1u);
  EXPECT_EQ(f.changes(), 3u);
  EXPECT_FALSE(f.due(t0 + 10s));
  EXPECT_FALSE(f.wait(t0 + 10s));
}

TEST(NetworkFollower, ChangesThatChangeNothingCostNothing) {
  NetworkFollower f({eth("eth0", {"10.0.0.5"})});
  f.changed({eth("eth0", {"10.0.0.5"})}, t0);  // a DHCP renewal, an IPv6 address
  EXPECT_FALSE(f.due(t0 + 1s));
  f.changed({}, t0 + 2s);                        // the link flickers down ...
  f.changed({eth("eth0", {"10.0.0.5"})}, t0 + 2100ms);  // ... and up within the settle time
  EXPECT_FALSE(f.due(t0 + 3s));
  EXPECT_EQ(f.refreshes(), 0u);
}

TEST(NetworkFollower, RenumberedOrSecondInterfaceIsAChange) {
  NetworkFollower f({eth("eth0", {"10.0.0.5"})});
  f.changed({eth("eth0", {"10.9.0.5"})}, t0);
  ASSERT_TRUE(f.due(t0 + 300ms));
  f.changed({eth("eth0", {"10.9.0.5"}), eth("eth1", {"10.1.0.1"})}, t0 + 5s);
  const auto chosen = f.due(t0 + 5300ms);  // more than the back-off (1 s) after the last
  ASSERT_TRUE(chosen);
  EXPECT_EQ(names(*chosen), (std::vector<std::string>{"eth0", "eth1"}));
  EXPECT_EQ(f.joined(), *chosen);
}

TEST(NetworkFollower, AFlappingHostIsBackedOffAndCounted) {
  // Addresses flap every second for a minute (a bad DHCP server).
  NetworkFollower f({eth("eth0", {"10.0.0.5"})});
  int refreshes = 0;
  for (int s = 0; s < 60; ++s) {
    const auto at = t0 + std::chrono::seconds(s);
    f.changed({eth("eth0", {s % 2 ? "10.0.0.5" : "10.0.0.6"})}, at);
    for (auto t = at; t < at + 1s; t += 50ms) refreshes += f.due(t).has_value();
  }
  // Spaced 1, 2, 4, 8, 16, 30 s at most: a handful, not sixty.
  EXPECT_LE(refreshes, 8);
  EXPECT_GE(refreshes, 4);
  EXPECT_EQ(f.changes(), 60u);
  // A quiet minute later, a change is followed at once again.
  f.changed({eth("eth0", {"10.0.0.7"})}, t0 + 200s);
  EXPECT_TRUE(f.due(t0 + 200s + 300ms));
}
