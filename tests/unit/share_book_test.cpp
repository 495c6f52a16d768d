// ShareBook and the shared-usb wire document (issue 25): what another host's shared
// USB camera becomes in the table, what is refused and counted, when it leaves.
// Driven with made-up instances, participants and times against a real (plain)
// table: no Cyclone, no network.
#include "dds/share_book.hpp"
#include "dds/shared_usb.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace std::chrono_literals;
using nlohmann::json;
using rsd::dds::ShareBook;
using rsd::dds::ShareBookOptions;

namespace {

const ShareBook::Clock::time_point t0{};

// A local camera as host `host`'s USB source lists it.
json local_camera(const std::string& serial) {
  return {{"id", "usb-" + serial},
          {"source", "usb"},
          {"sources", {"usb"}},
          {"name", "Intel RealSense D455"},
          {"serial", serial},
          {"product-id", "0B5C"},
          {"product-line", "D400"},
          {"recovery", false},
          {"first-seen", "2026-01-01T00:00:00.000Z"},
          {"usb",
           {{"bus", 2}, {"address", 3}, {"port-path", "2-1"}, {"speed", "super"}, {"vid", "8086"}, {"pid", "0B5C"},
            {"speed-mbps", 5000}, {"sysfs-path", "/sys/devices/pci0000:00/usb2/2-1"}}}};
}

std::span<const std::uint8_t> bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

// What a sharer on `host` writes for its camera `serial`, as the reader parses it.
std::variant<rsd::dds::SharedCamera, rsd::dds::Rejected> shared(const std::string& host, const std::string& serial,
                                                                const std::string& participant = "p-a") {
  const std::string payload = rsd::dds::shared_usb_payload(host, {"10.0.0.1"}, local_camera(serial));
  return rsd::dds::parse_shared_usb(7, host, "usb-" + serial, 1, bytes(payload), participant);
}

std::string reason(const std::variant<rsd::dds::SharedCamera, rsd::dds::Rejected>& v) {
  const auto* r = std::get_if<rsd::dds::Rejected>(&v);
  return r ? r->reason : "(accepted)";
}

struct Share : ::testing::Test {
  rsd::SharedTable table;
  ShareBookOptions options = [] {
    ShareBookOptions o;
    o.domain = 7;
    o.max_per_participant = 3;
    o.max_per_domain = 5;
    return o;
  }();
  ShareBook book{table, options};

  std::vector<std::string> ids() {
    std::vector<std::string> out;
    for (const auto& e : table.snapshot().devices) out.push_back(e->device.id);
    return out;
  }
  std::uint64_t rejected(const std::string& r) {
    rsd::DomainStatus s;
    book.fill(s);
    return s.rejected.count(r) ? s.rejected.at(r) : 0;
  }
};

}  // namespace

TEST_F(Share, AnotherHostsCameraIsListedAsRemoteUsbWithItsHost) {
  book.sample(1, "p-a", shared("rig-a", "123622270732"));
  const auto dev = table.find("usb-123622270732.rig-a");
  ASSERT_TRUE(dev);
  EXPECT_EQ((*dev)["source"], "remote-usb");
  EXPECT_EQ((*dev)["sources"], json::array({"remote-usb"}));
  EXPECT_EQ((*dev)["serial"], "123622270732");
  EXPECT_EQ((*dev)["name"], "Intel RealSense D455");
  EXPECT_EQ((*dev)["domain"], 7);
  EXPECT_EQ((*dev)["host"]["name"], "rig-a");
  EXPECT_EQ((*dev)["host"]["addresses"], json::array({"10.0.0.1"}));
  EXPECT_EQ((*dev)["host"]["participant-guid"], "p-a");
  EXPECT_EQ((*dev)["usb"]["port-path"], "2-1");
  // A path on the other host's file system says nothing here.
  EXPECT_FALSE((*dev)["usb"].contains("sysfs-path"));
  const auto typed = table.find_entry("usb-123622270732.rig-a");
  ASSERT_TRUE(typed && typed->device.host);
  EXPECT_EQ(typed->device.source, rsd::model::Source::remote_usb);
}

TEST_F(Share, TheSameSerialFromTwoHostsIsTwoEntriesAndNeverMergesWithLocalUsb) {
  table.upsert("usb-123", local_camera("123"));  // this host's own camera of that serial
  book.sample(1, "p-a", shared("rig-a", "123", "p-a"));
  book.sample(2, "p-b", shared("rig-b", "123", "p-b"));
  EXPECT_EQ(ids(), (std::vector<std::string>{"usb-123", "usb-123.rig-a", "usb-123.rig-b"}));
  EXPECT_EQ((*table.find("usb-123"))["sources"], json::array({"usb"}));
}

TEST_F(Share, DisposedOrWriterlessInstanceLeavesTheTable) {
  book.sample(1, "p-a", shared("rig-a", "1"));
  book.sample(2, "p-a", shared("rig-a", "2"));
  book.instance_gone(1, true, t0);
  EXPECT_EQ(ids(), (std::vector<std::string>{"usb-2.rig-a"}));
  book.instance_gone(1, true, t0);  // again: nothing
  // No writer left (lease expired): gone once the grace passes without a new writer.
  book.instance_gone(2, false, t0);
  book.tick(t0 + 1s);
  EXPECT_EQ(ids(), (std::vector<std::string>{"usb-2.rig-a"}));
  book.tick(t0 + 2s);
  EXPECT_TRUE(ids().empty());
}

// A sharer on two domains this daemon is on too: one camera, one entry, which stays
// while either domain still has it (the sharer's lease on one ran out) and shows the
// lower domain's document.
TEST_F(Share, ACameraSharedOnTwoDomainsStaysWhileEitherHasIt) {
  ShareBookOptions other = options;
  other.domain = 8;
  ShareBook book8{table, other};
  const std::string payload = rsd::dds::shared_usb_payload("rig-a", {"10.0.0.1"}, local_camera("1"));
  book.sample(1, "p-a", shared("rig-a", "1"));
  book8.sample(1, "p-a8", rsd::dds::parse_shared_usb(8, "rig-a", "usb-1", 1, bytes(payload), "p-a8"));
  EXPECT_EQ(ids(), (std::vector<std::string>{"usb-1.rig-a"}));
  EXPECT_EQ(table.find_entry("usb-1.rig-a")->device.domain, 7);
  const auto generation = table.generation();
  book.instance_gone(1, true, t0);  // unshared on 7 (or its lease there ran out)
  ASSERT_EQ(ids(), (std::vector<std::string>{"usb-1.rig-a"}));
  EXPECT_EQ(table.find_entry("usb-1.rig-a")->device.domain, 8);
  EXPECT_EQ(table.generation(), generation + 1);  // one `changed`, no removal
  book.sample(2, "p-a", shared("rig-a", "1"));  // back on 7
  EXPECT_EQ(table.find_entry("usb-1.rig-a")->device.domain, 7);
  book8.forget_devices(rsd::model::RemovalReason::domain_left);
  book.forget_devices(rsd::model::RemovalReason::domain_left);
  EXPECT_TRUE(ids().empty());
}

TEST_F(Share, OwnParticipantsSamplesNeverBecomeEntries) {
  book.set_own_participant("me");
  book.sample(1, "me", shared("this-host", "1", "me"));
  EXPECT_TRUE(ids().empty());
}

TEST_F(Share, ARepeatedSampleIsNoEventAndAChangeIsOne) {
  book.sample(1, "p-a", shared("rig-a", "1"));
  const auto g = table.generation();
  book.sample(1, "p-a", shared("rig-a", "1"));
  EXPECT_EQ(table.generation(), g);
  auto changed = local_camera("1");
  changed["usb"]["port-path"] = "2-2";
  const std::string payload = rsd::dds::shared_usb_payload("rig-a", {"10.0.0.1"}, changed);
  book.sample(1, "p-a", rsd::dds::parse_shared_usb(7, "rig-a", "usb-1", 1, bytes(payload), "p-a"));
  EXPECT_GT(table.generation(), g);
  EXPECT_EQ((*table.find("usb-1.rig-a"))["usb"]["port-path"], "2-2");
}

TEST_F(Share, CapsPerParticipantAndPerDomainAreCounted) {
  for (std::uint64_t i = 1; i <= 5; ++i) book.sample(i, "flooder", shared("rig-f", std::to_string(i), "flooder"));
  EXPECT_EQ(ids().size(), 3u);
  EXPECT_EQ(rejected("shared-participant-limit"), 2u);
  book.sample(10, "p-b", shared("rig-b", "10", "p-b"));
  book.sample(11, "p-b", shared("rig-b", "11", "p-b"));
  book.sample(12, "p-b", shared("rig-b", "12", "p-b"));
  EXPECT_EQ(ids().size(), 5u);
  EXPECT_EQ(rejected("shared-domain-limit"), 1u);
  // Room again once one leaves.
  book.instance_gone(1, true, t0);
  book.sample(12, "p-b", shared("rig-b", "12", "p-b"));
  EXPECT_TRUE(table.find("usb-12.rig-b"));
}

TEST_F(Share, ABadSampleIsCountedAndKeepsTheLastGoodDocument) {
  book.sample(1, "p-a", shared("rig-a", "1"));
  book.sample(1, "p-a", rsd::dds::parse_shared_usb(7, "rig-a", "usb-1", 1, bytes("{not json"), "p-a"));
  EXPECT_EQ(rejected("shared-not-json"), 1u);
  EXPECT_TRUE(table.find("usb-1.rig-a"));
}

TEST_F(Share, ANewReaderKeepsCamerasHeardAgainAndDropsTheOthers) {
  book.sample(1, "p-a", shared("rig-a", "1"));
  book.sample(2, "p-a", shared("rig-a", "2"));
  const auto g = table.generation();
  book.reader_made(t0);
  book.sample(7, "p-a", shared("rig-a", "1"));  // a new handle for the same camera
  EXPECT_EQ(table.generation(), g);              // no event: nothing changed
  book.tick(t0 + 1s);
  EXPECT_EQ(ids().size(), 2u);
  book.tick(t0 + 3s);
  EXPECT_EQ(ids(), (std::vector<std::string>{"usb-1.rig-a"}));
  book.instance_gone(7, true, t0 + 3s);
  EXPECT_TRUE(ids().empty());
}

TEST_F(Share, ASharerMadeAnewTakesItsCamerasOverWithoutAnEvent) {
  book.sample(1, "p-a", shared("rig-a", "1", "p-a"));
  const auto g = table.generation();
  book.instance_gone(1, false, t0);                      // its old participant's writer went
  book.sample(9, "p-a2", shared("rig-a", "1", "p-a2"));  // the new one's wrote the same camera
  book.tick(t0 + 5s);
  EXPECT_EQ(ids(), (std::vector<std::string>{"usb-1.rig-a"}));
  EXPECT_EQ(table.generation(), g + 1);  // the host's participant GUID changed, nothing else
  EXPECT_EQ((*table.find("usb-1.rig-a"))["host"]["participant-guid"], "p-a2");
}

TEST_F(Share, ForgetDevicesTakesEveryCameraOut) {
  book.sample(1, "p-a", shared("rig-a", "1"));
  book.reader_made(t0);
  book.sample(2, "p-a", shared("rig-a", "2"));
  book.forget_devices(rsd::model::RemovalReason::domain_left);
  EXPECT_TRUE(ids().empty());
}

TEST(SharedUsbWire, MalformedDocumentsAreRejectedWithAReason) {
  const auto parse = [](const std::string& host, const std::string& camera, std::uint8_t version,
                        const std::string& data) {
    return reason(rsd::dds::parse_shared_usb(3, host, camera, version, bytes(data), "p"));
  };
  const std::string good = rsd::dds::shared_usb_payload("h", {"192.0.2.1", "fe80::1"}, local_camera("9"));
  EXPECT_EQ(parse("h", "usb-9", 1, good), "(accepted)");
  EXPECT_EQ(parse("h", "usb-9", 2, good), "shared-version");
  EXPECT_EQ(parse("", "usb-9", 1, good), "shared-bad-key");
  EXPECT_EQ(parse("h\x1b[2J", "usb-9", 1, good), "shared-bad-key");
  EXPECT_EQ(parse("h", "dds-1-x", 1, good), "shared-bad-key");
  EXPECT_EQ(parse("h", "usb-9/../x", 1, good), "shared-bad-key");
  EXPECT_EQ(parse("other", "usb-9", 1, good), "shared-bad-host");  // the document's host is not the key's
  EXPECT_EQ(parse("h", "usb-9", 1, ""), "shared-empty");
  EXPECT_EQ(parse("h", "usb-9", 1, "[1]"), "shared-not-object");
  EXPECT_EQ(parse("h", "usb-9", 1, std::string(5000, ' ')), "shared-too-large");
  EXPECT_EQ(parse("h", "usb-9", 1, R"({"host":{"name":"h","addresses":["not-an-ip"]},"device":{"name":"x"}})"),
            "shared-bad-host");
  EXPECT_EQ(parse("h", "usb-9", 1, R"({"host":{"name":"h"},"device":{"serial":"9"}})"), "shared-bad-device");
  EXPECT_EQ(parse("h", "usb-9", 1, R"({"host":{"name":"h"},"device":{"name":"\u0007bell"}})"), "shared-bad-device");
  std::string addresses;
  for (int i = 0; i < 17; ++i) addresses += std::string(i ? "," : "") + "\"10.0.0." + std::to_string(i) + "\"";
  EXPECT_EQ(parse("h", "usb-9", 1, R"({"host":{"name":"h","addresses":[)" + addresses + R"(]},"device":{"name":"x"}})"),
            "shared-bad-host");
}

TEST(SharedUsbWire, OnlyTheCamerasOwnFieldsAreKept) {
  const auto v = rsd::dds::parse_shared_usb(
      3, "h", "usb-9", 1,
      bytes(R"({"host":{"name":"h"},"device":{"name":"x","id":"dds-1-evil","source":"usb","domain":99,)"
            R"("server":{},"topic-root":"realsense/x","extra-key":1,"warnings":["w1","\u0001"]}})"),
      "p");
  const auto* cam = std::get_if<rsd::dds::SharedCamera>(&v);
  ASSERT_TRUE(cam);
  EXPECT_EQ(cam->id, "usb-9.h");
  EXPECT_EQ(cam->device, json::parse(R"({"source":"remote-usb","name":"x","recovery":false,"domain":3,)"
                                     R"("warnings":["w1"],"host":{"name":"h","addresses":[],"participant-guid":"p"}})"));
}

TEST(SharedUsbWire, IdsAreUrlSafeAndDistinctPerHost) {
  EXPECT_EQ(rsd::dds::shared_usb_id("rig-a", "usb-1"), "usb-1.rig-a");
  // The host's '.' escaped: the last '.' starts the host, so no two keys share an id.
  EXPECT_EQ(rsd::dds::shared_usb_id("rig-a.lab", "usb-1.x"), "usb-1.x.rig-a~2Elab");
  EXPECT_NE(rsd::dds::shared_usb_id("x.lab", "usb-1"), rsd::dds::shared_usb_id("lab", "usb-1.x"));
  EXPECT_EQ(rsd::dds::shared_usb_id("a b/c~", "usb-1"), "usb-1.a~20b~2Fc~7E");
  EXPECT_NE(rsd::dds::shared_usb_id("a~20b", "usb-1"), rsd::dds::shared_usb_id("a b", "usb-1"));
}
