// spdp::parse, the doctor's reader of RTPS participant announcements, on one a
// realdds server (pyrealsense2 2.59.1, Fast DDS) sent, and on every way of cutting
// or corrupting it: it reads the name and addresses, and never reads past the end.
#include "spdp.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace {

// Captured on domain 150's discovery port (239.255.0.1:44900) from a realdds server
// started as tests/tools/realdds_server.py --domain 150 --name elsewhere-server, in
// a network namespace whose interface had 10.99.0.1: INFO_TS, then DATA(p).
const std::string kRealddsSpdp =
    "525450530202010f010f0d048a26b140000000000901080064cd0f6b30f88a8d1505d40000001000000100c7000100c2"
    "000000000100000000030000150004000202000016000400010f000050001000010f0d048a26b14000000000000001c1"
    "32001800010000006eaf00000000000000000000000000000a63000131001800010000006faf00000000000000000000"
    "000000000a630001020008000300000000000000580004003f0c00006200180011000000656c736577686572652d7365"
    "72766572000000005900280001000000110000005041525449434950414e545f54595045000000000700000053494d50"
    "4c45000001000000";

std::vector<std::uint8_t> bytes(const std::string& hex) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) out.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return out;
}

TEST(Spdp, ReadsARealddsServersAnnouncement) {
  const auto msg = bytes(kRealddsSpdp);
  const auto a = rsdiscover::spdp::parse(msg.data(), msg.size(), 150);
  ASSERT_TRUE(a);
  EXPECT_EQ(a->domain, 150);
  EXPECT_EQ(a->name, "elsewhere-server");
  EXPECT_EQ(a->vendor_id, "01.0f");
  EXPECT_EQ(a->guid_prefix, "010f0d04.8a26b140.00000000");
  EXPECT_EQ(a->addresses, std::vector<std::string>{"10.99.0.1"});
}

TEST(Spdp, CutShortOrCorruptedItIsRefusedOrReadWithinBounds) {
  const auto msg = bytes(kRealddsSpdp);
  for (std::size_t n = 0; n < msg.size(); ++n) {
    // A copy of exactly n bytes, so that AddressSanitizer sees any read past it.
    const std::vector<std::uint8_t> cut(msg.begin(), msg.begin() + static_cast<long>(n));
    const auto a = rsdiscover::spdp::parse(cut.data(), cut.size(), 0);
    if (a) {
      EXPECT_EQ(a->guid_prefix, "010f0d04.8a26b140.00000000");
    }
  }
  for (std::size_t i = 0; i < msg.size(); ++i)
    for (std::uint8_t v : {std::uint8_t{0}, std::uint8_t{0xff}, std::uint8_t{0x7f}}) {
      auto bad = msg;
      bad[i] = v;
      (void)rsdiscover::spdp::parse(bad.data(), bad.size(), 0);
    }
}

TEST(Spdp, OtherMessagesCarryNoAnnouncement) {
  const std::vector<std::uint8_t> junk = {'R', 'T', 'P', 'X', 2, 2, 1, 15};
  EXPECT_FALSE(rsdiscover::spdp::parse(junk.data(), junk.size(), 0));
  auto msg = bytes(kRealddsSpdp);
  msg[20 + 12 + 4 + 8 + 3] = 0xc7;  // the DATA's writer is another one (not the SPDP writer)
  EXPECT_FALSE(rsdiscover::spdp::parse(msg.data(), msg.size(), 0));
}

}  // namespace
