// One camera seen on DDS and on USB: the table's merge by exact serial.
#include "table/device_table.hpp"

#include <gtest/gtest.h>

using nlohmann::json;
using rsd::DeviceTable;
using rsd::EventType;

namespace {
json dds(const std::string& serial, int domain = 7) {
  return {{"source", "dds"},
          {"domain", domain},
          {"topic-root", "realsense/D455_" + serial},
          {"name", "Intel RealSense D455"},
          {"serial", serial},
          {"fw-version", "5.16.0.1"}};
}
json usb(const std::string& serial) {
  return {{"source", "usb"},
          {"name", "Intel RealSense D455"},
          {"serial", serial},
          {"product-id", "0B5C"},
          {"usb", {{"bus", 2}, {"port-path", "2-1"}}}};
}
std::vector<std::string> ids(const DeviceTable& t) {
  std::vector<std::string> out;
  for (const auto& d : t.devices()) out.push_back(d["id"]);
  return out;
}
}  // namespace

TEST(TableMerge, SingleSourceEntriesListTheirSource) {
  DeviceTable t;
  t.upsert("usb-1", usb("1"), "T1");
  EXPECT_EQ(t.find("usb-1")->json()["sources"], json::array({"usb"}));
  EXPECT_EQ(t.find("usb-1")->json()["source"], "usb");
}

TEST(TableMerge, SameSerialMergesUnderTheDdsId) {
  DeviceTable t;
  t.upsert("usb-123", usb("123"), "T1");  // 1 added
  auto ev = t.upsert("dds-7-x", dds("123"), "T2");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::added);
  EXPECT_EQ(ev->device()["id"], "dds-7-x");
  EXPECT_EQ(ids(t), std::vector<std::string>{"dds-7-x"});
  const json d = t.find("dds-7-x")->json();
  EXPECT_EQ(d["source"], "dds");
  EXPECT_EQ(d["sources"], json::array({"dds", "usb"}));
  EXPECT_EQ(d["domain"], 7);
  EXPECT_EQ(d["usb"]["port-path"], "2-1");      // filled from the USB sighting
  EXPECT_EQ(d["product-id"], "0B5C");           // absent on DDS: filled
  EXPECT_EQ(d["first-seen"], "T1");             // earliest sighting
  EXPECT_EQ(d["last-seen"], "T2");
  // The USB id still finds the camera.
  ASSERT_NE(t.find("usb-123"), nullptr);
  EXPECT_EQ(t.find("usb-123")->json()["id"], "dds-7-x");
  // The log: added usb, removed usb (merged-into), added dds.
  auto log = t.events_since(0).events;
  ASSERT_EQ(log.size(), 3u);
  EXPECT_EQ(log[1].type, EventType::removed);
  EXPECT_EQ(log[1].device()["id"], "usb-123");
  EXPECT_EQ(log[1].device()["merged-into"], "dds-7-x");
  EXPECT_EQ(log[2].type, EventType::added);
}

TEST(TableMerge, UsbJoiningDdsIsAChange) {
  DeviceTable t;
  t.upsert("dds-7-x", dds("123"), "T1");
  auto ev = t.upsert("usb-123", usb("123"), "T2");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::changed);
  EXPECT_EQ(ev->device()["id"], "dds-7-x");
  EXPECT_EQ(ev->device()["sources"], json::array({"dds", "usb"}));
  EXPECT_EQ(t.size(), 1u);
  EXPECT_EQ(t.generation(), 2u);
}

TEST(TableMerge, UnplugLeavesDdsAndDdsLeavingLeavesUsb) {
  DeviceTable t;
  t.upsert("dds-7-x", dds("123"), "T1");
  t.upsert("usb-123", usb("123"), "T2");
  auto ev = t.remove("usb-123", rsd::model::RemovalReason::stopping, "T9");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::changed);
  EXPECT_EQ(ev->device()["sources"], json::array({"dds"}));
  EXPECT_FALSE(ev->device().contains("usb"));
  EXPECT_EQ(ids(t), std::vector<std::string>{"dds-7-x"});
  EXPECT_EQ(t.find("usb-123"), nullptr);

  t.upsert("usb-123", usb("123"), "T3");
  ev = t.remove("dds-7-x", rsd::model::RemovalReason::stopping, "T9");
  ASSERT_TRUE(ev);
  EXPECT_EQ(ev->type, EventType::removed);
  EXPECT_EQ(ev->device()["id"], "dds-7-x");
  EXPECT_FALSE(ev->device().contains("merged-into"));
  EXPECT_EQ(ids(t), std::vector<std::string>{"usb-123"});
  const json u = t.find("usb-123")->json();
  EXPECT_EQ(u["source"], "usb");
  EXPECT_EQ(u["sources"], json::array({"usb"}));
  EXPECT_EQ(u["first-seen"], "T3");
  EXPECT_FALSE(u.contains("domain"));
  auto last = t.events_since(t.generation() - 2).events;
  ASSERT_EQ(last.size(), 2u);
  EXPECT_EQ(last[0].type, EventType::removed);
  EXPECT_EQ(last[1].type, EventType::added);
  EXPECT_EQ(last[1].device()["id"], "usb-123");
}

TEST(TableMerge, DifferentOrMissingSerialsNeverMerge) {
  DeviceTable t;
  t.upsert("dds-7-x", dds("123"), "T");
  t.upsert("usb-1234", usb("1234"), "T");   // a prefix is not a match
  t.upsert("usb-0123", usb("0123"), "T");
  json blank = usb("");
  t.upsert("usb-port-1-4", blank, "T");
  json noserial = dds("x");
  noserial.erase("serial");
  t.upsert("dds-7-y", noserial, "T");
  EXPECT_EQ(t.size(), 5u);
  EXPECT_EQ(t.find("dds-7-x")->json()["sources"], json::array({"dds"}));
}

TEST(TableMerge, DocumentsWithoutSourceNeverMerge) {
  DeviceTable t;
  t.upsert("a", {{"serial", "1"}}, "T");
  t.upsert("b", {{"serial", "1"}}, "T");
  EXPECT_EQ(t.size(), 2u);
  EXPECT_FALSE(t.find("a")->json().contains("sources"));
}

TEST(TableMerge, OneSightingPerSourceJoins) {
  DeviceTable t;
  t.upsert("dds-8-x", dds("5", 8), "T");
  t.upsert("dds-7-x", dds("5", 7), "T");
  t.upsert("usb-5", usb("5"), "T");
  // Lowest DDS id names the merged entry; the other DDS sighting stays on its own.
  EXPECT_EQ(ids(t), (std::vector<std::string>{"dds-7-x", "dds-8-x"}));
  EXPECT_EQ(t.find("dds-7-x")->json()["sources"], json::array({"dds", "usb"}));
  EXPECT_EQ(t.find("dds-8-x")->json()["sources"], json::array({"dds"}));
  t.remove("dds-7-x", rsd::model::RemovalReason::stopping, "T9");
  EXPECT_EQ(ids(t), std::vector<std::string>{"dds-8-x"});
  EXPECT_EQ(t.find("dds-8-x")->json()["sources"], json::array({"dds", "usb"}));
}

TEST(TableMerge, SerialChangeMovesTheSighting) {
  DeviceTable t;
  t.upsert("dds-7-x", dds("1"), "T");
  t.upsert("usb-1", usb("1"), "T");
  json changed = dds("2");
  t.upsert("dds-7-x", changed, "T");  // the DDS server now reports another serial
  EXPECT_EQ(ids(t), (std::vector<std::string>{"dds-7-x", "usb-1"}));
  EXPECT_EQ(t.find("dds-7-x")->json()["sources"], json::array({"dds"}));
  EXPECT_EQ(t.find("usb-1")->json()["sources"], json::array({"usb"}));
}

TEST(TableMerge, ReannouncingAMergedDeviceIsNotNews) {
  DeviceTable t;
  t.upsert("dds-7-x", dds("1"), "T1");
  t.upsert("usb-1", usb("1"), "T1");
  const auto g = t.generation();
  EXPECT_FALSE(t.upsert("dds-7-x", dds("1"), "T2"));
  EXPECT_EQ(t.generation(), g);
  EXPECT_EQ(t.find("dds-7-x")->json()["last-seen"], "T2");
}

TEST(TableMerge, RemoveIfSeesSightingsNotEntries) {
  DeviceTable t;
  t.upsert("dds-7-x", dds("1"), "T");
  t.upsert("usb-1", usb("1"), "T");
  t.upsert("usb-2", usb("2"), "T");
  auto events = t.remove_if([](const rsd::model::Device& d) { return d.source == rsd::model::Source::usb; }, rsd::model::RemovalReason::domain_left, "T9");
  EXPECT_EQ(events.size(), 2u);  // dds-7-x changed, usb-2 removed
  EXPECT_EQ(ids(t), std::vector<std::string>{"dds-7-x"});
  EXPECT_FALSE(t.find("dds-7-x")->json().contains("usb"));
  // The domain's DDS side torn down: the USB camera would stay.
  t.upsert("usb-1", usb("1"), "T");
  t.remove_if([](const rsd::model::Device& d) { return d.domain == 7; }, rsd::model::RemovalReason::domain_left, "T9");
  EXPECT_EQ(ids(t), std::vector<std::string>{"usb-1"});
}

TEST(TableMerge, SourcesCannotForgeTableFields) {
  DeviceTable t;
  json doc = usb("1");
  doc["sources"] = {"dds", "usb"};
  doc["merged-into"] = "x";
  t.upsert("usb-1", doc, "T");
  EXPECT_EQ(t.find("usb-1")->json()["sources"], json::array({"usb"}));
  EXPECT_FALSE(t.find("usb-1")->json().contains("merged-into"));
}

TEST(TableMerge, EntriesAreTypedThroughTheMerge) {
  DeviceTable t;
  t.upsert("usb-123", usb("123"), "T1");
  t.upsert("dds-7-x", dds("123"), "T2");
  const auto merged = t.find("usb-123");
  ASSERT_TRUE(merged);
  EXPECT_EQ(merged->device.id, "dds-7-x");
  EXPECT_EQ(merged->device.source, rsd::model::Source::dds);
  EXPECT_EQ(merged->device.sources, (std::vector<rsd::model::Source>{rsd::model::Source::dds, rsd::model::Source::usb}));
  EXPECT_TRUE(merged->device.seen_by(rsd::model::Source::usb));
  EXPECT_EQ(merged->device.domain, 7);
  // The USB entry's last event names where it went, typed and in its text.
  const auto log = t.events_since(0).events;
  ASSERT_EQ(log.size(), 3u);
  EXPECT_EQ(log[1].entry->device.merged_into, "dds-7-x");
  EXPECT_NE(log[1].entry->text.find(R"("merged-into":"dds-7-x")"), std::string::npos);
}
