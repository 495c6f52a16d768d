// The device model: what it reads it writes back unchanged, whatever a peer sent; the
// lookup rule; the default-socket rule the daemon and the clients share.
#include "rsd_model/clients.hpp"
#include "rsd_model/device.hpp"
#include "rsd_model/description.hpp"
#include "rsd_model/participant.hpp"
#include "rsd_model/status.hpp"
#include "rsd_model/socket_path.hpp"

#include <gtest/gtest.h>

using nlohmann::json;
using namespace rsd::model;

namespace {

TEST(Model, ReadsADdsDeviceAndWritesItBackUnchanged) {
  auto doc = json::parse(R"({"id":"dds-7-realsense.D455_1","source":"dds","sources":["dds"],"domain":7,
    "topic-root":"realsense/D455_1","name":"Intel RealSense D455","serial":"1","product-line":"D400",
    "product-id":"0B5C","fw-version":"5.16.0.1","recovery":false,"first-seen":"2026-11-23T13:10:20.123Z",
    "last-seen":"2026-11-23T13:10:21.000Z","multicast-ip":"239.0.0.1",
    "server":{"participant-guid":"g","participant-name":"n","addresses":["192.168.1.5"],"writer-guid":"w"}})");
  auto d = device_from_json(doc);
  EXPECT_EQ(d.source, Source::dds);
  EXPECT_EQ(d.domain, 7);
  ASSERT_TRUE(d.server);
  EXPECT_EQ(d.server->writer_guid, "w");
  EXPECT_EQ(d.extra, json({{"multicast-ip", "239.0.0.1"}}));  // the camera's own key, verbatim
  EXPECT_EQ(d.state(), DeviceState::ok);
  EXPECT_EQ(to_json(d), doc);
}

TEST(Model, WhatTheTypesCannotHoldStaysVerbatim) {
  // A peer's device-info may say anything: a numeric serial, a "usb" of its own...
  for (const char* text : {R"({"id":"x","serial":123,"usb":"no","warnings":[],"server":{"odd":1}})",
                           R"({"id":"","source":"ethernet","sources":["dds","x"],"domain":-1e3})",
                           R"({"usb":{"bus":1,"address":2,"port-path":"1-1","speed":"high","vid":"8086"}})",
                           R"({"recovery":"yes","merged-into":5,"domain":99999999999})"}) {
    auto doc = json::parse(text);
    EXPECT_EQ(to_json(device_from_json(doc)), doc) << text;
  }
  EXPECT_EQ(device_from_json(json::parse(R"({"serial":123})")).serial, std::nullopt);
}

TEST(Model, InUseAndClientsRoundTrip) {
  auto doc = json::parse(R"({"id":"dds-0-r","in-use":{"clients":2,"streaming":["Depth"]}})");
  auto d = device_from_json(doc);
  ASSERT_TRUE(d.in_use);
  EXPECT_EQ(*d.in_use, (InUse{2, {"Depth"}}));
  EXPECT_TRUE(d.used());
  EXPECT_EQ(to_json(d), doc);
  // Anything else under the key is a peer's: verbatim in extra, not in use.
  auto odd = json::parse(R"({"id":"x","in-use":{"clients":-1,"streaming":[]}})");
  EXPECT_FALSE(device_from_json(odd).used());
  EXPECT_EQ(to_json(device_from_json(odd)), odd);

  DeviceClients c;
  c.clients.push_back({"g", "app", Vendor::cyclone_dds, "01.10", {"192.0.2.1"}, "pc", "python", 42, "T", {"Depth"},
                       {"/robot/viewer"}});
  c.streams = {{"Depth", 1}};
  const auto text = to_json(c);
  EXPECT_EQ(text["clients"][0]["ros-nodes"], json::array({"/robot/viewer"}));
  EXPECT_EQ(summary_of(c), (InUse{1, {"Depth"}}));
}

TEST(Model, ReadinessRoundTripsAndAWrongTypeStaysVerbatim) {
  auto doc = json::parse(R"({"id":"x","ready":false,"ready-stage":"stream 1 of 2"})");
  const Device d = device_from_json(doc);
  EXPECT_EQ(d.ready, false);
  EXPECT_EQ(d.ready_stage, "stream 1 of 2");
  EXPECT_EQ(to_json(d), doc);
  auto odd = json::parse(R"({"id":"x","ready":"no"})");
  EXPECT_FALSE(device_from_json(odd).ready);
  EXPECT_EQ(to_json(device_from_json(odd)), odd);
}

TEST(Model, StateAndLookup) {
  Device d;
  d.serial = "123";
  d.topic_root = "realsense/D435_123";
  d.warnings = {"USB 2"};
  EXPECT_EQ(d.state(), DeviceState::warning);
  d.recovery = true;
  EXPECT_EQ(d.state(), DeviceState::recovery);  // recovery firmware is told first
  EXPECT_TRUE(d.named_by("123"));
  EXPECT_TRUE(d.named_by("realsense/D435_123"));
  EXPECT_FALSE(d.named_by("12"));
  EXPECT_FALSE(d.named_by(""));
}

TEST(Model, UsbSpeedIsAnIntegerWhenWhole) {
  Device d;
  d.usb = Usb{1, 2, "1-1", "high", "8086", "0B07", 480.0, std::nullopt, std::nullopt, {}};
  EXPECT_EQ(to_json(d)["usb"]["speed-mbps"].dump(), "480");
  d.usb->speed_mbps = 1.5;
  EXPECT_EQ(to_json(d)["usb"]["speed-mbps"].dump(), "1.5");
}

TEST(Model, DefaultSocketRule) {
  EXPECT_EQ(default_socket_path("/run/a:/run/b", "/x", 1000), "/run/a/api.sock");
  EXPECT_EQ(default_socket_path(nullptr, "/run/user/1000", 0), kSystemSocket);
  EXPECT_EQ(default_socket_path("", "/run/user/1000", 1000), "/run/user/1000/rs-discoveryd.sock");
  EXPECT_EQ(default_socket_path(nullptr, "", 1000), "/tmp/rs-discoveryd-1000.sock");
  EXPECT_EQ(default_socket_path(nullptr, nullptr, 1000), "/tmp/rs-discoveryd-1000.sock");
}

}  // namespace

// ---- status documents -------------------------------------------------------------------

TEST(StatusModel, DomainStatusWritesEveryKey) {
  rsd::model::DomainStatus s;
  s.domain = 7;
  s.state = rsd::model::DomainState::rebuilding;
  s.participant_guid = "01107948.66908ead.429992d1.000001c1";
  s.devices = 3;
  s.accepted = 12;
  s.stopping = 1;
  s.rejected = {{"malformed", 2}};
  s.rebuilds = 4;
  s.refreshes = 2;
  s.lost_servers = 1;
  s.writers = 9;
  s.writers_refused = {{"domain-writer-limit", 5}};
  s.endpoints_refused = {{"topic-name-too-long", 3}};
  s.interfaces = {{"eth0", {"192.0.2.2"}}, {"eth1", {"10.1.0.1", "10.1.0.2"}}};
  s.network_changes = 2;
  s.network_changed_at = "2026-12-02T08:50:00.000Z";
  s.complete = true;
  const auto doc = rsd::model::to_json(s);
  EXPECT_EQ(doc.size(), 18u);  // the spec's DomainStatus, every required key
  EXPECT_EQ(doc["interfaces"][1]["addresses"][1], "10.1.0.2");
  EXPECT_EQ(doc["state"], "rebuilding");
  EXPECT_EQ(doc["lost-servers"], 1);
  EXPECT_EQ(doc["device-info-writers"], 9);
  EXPECT_EQ(doc["writers-refused"]["domain-writer-limit"], 5);
  EXPECT_EQ(doc["endpoints-refused"]["topic-name-too-long"], 3);
}

TEST(StatusModel, EveryDomainStateHasItsName) {
  using rsd::model::DomainState;
  for (auto st : {DomainState::settling, DomainState::running, DomainState::rebuilding, DomainState::failed,
                  DomainState::stopped})
    EXPECT_EQ(rsd::model::parse_domain_state(rsd::model::to_string(st)), st);
  EXPECT_FALSE(rsd::model::parse_domain_state("joining"));
}

TEST(StatusModel, HealthWritesUsbOffWithoutACount) {
  rsd::model::Health h;
  h.version = "0.1.0";
  h.devices = 2;
  h.generation = 99;
  h.complete = true;
  auto doc = rsd::model::to_json(h);
  EXPECT_EQ(doc["usb"], nlohmann::json({{"state", "off"}}));
  h.usb = {"unavailable", 0, "no /dev/bus/usb"};
  doc = rsd::model::to_json(h);
  EXPECT_EQ(doc["usb"]["error"], "no /dev/bus/usb");
  EXPECT_FALSE(doc.contains("http"));  // as an older daemon's
  h.http = rsd::model::HttpHealth{"127.0.0.1:8036", "127.0.0.1:8035", "systemd", false};
  doc = rsd::model::to_json(h);
  EXPECT_EQ(doc["http"], nlohmann::json({{"listening", "127.0.0.1:8036"}, {"configured", "127.0.0.1:8035"},
                                         {"from", "systemd"}, {"agrees", false}}));
}

// ---- the participant document ---------------------------------------------------------

TEST(ParticipantModel, WritesTheOptionalKeysOnlyWhenSaid) {
  Participant p;
  p.domain = 3;
  p.guid = "010f78fd.3e2482db.00000000.000001c1";
  p.name = "camera";
  p.vendor_id = vendor_id_of(p.guid);
  p.vendor = vendor_of(p.vendor_id);
  p.addresses = {"192.0.2.2"};
  p.first_seen = p.last_seen = "2026-11-24T06:50:45.206Z";
  auto doc = to_json(p);
  EXPECT_EQ(doc["vendor"], "fast-dds");
  EXPECT_EQ(doc["vendor-id"], "01.0f");
  EXPECT_FALSE(doc.contains("host"));
  p.host = "vm";
  p.process = "python";
  p.pid = 12;
  p.lease_seconds = 10.0;
  p.state = ParticipantState::gone;
  doc = to_json(p);
  EXPECT_EQ(doc.size(), 19u);  // the spec's Participant, every key
}

TEST(ParticipantModel, VendorsByTheirRtpsId) {
  EXPECT_EQ(vendor_of(vendor_id_of("0110b82b.a2cb9cf6.1994d528.000001c1")), Vendor::cyclone_dds);
  EXPECT_EQ(vendor_of(vendor_id_of("010f78fd.17307682.00000000.000001c1")), Vendor::fast_dds);
  EXPECT_EQ(vendor_of(vendor_id_of("0101aaaa.17307682.00000000.000001c1")), Vendor::rti_connext);
  EXPECT_EQ(vendor_of(vendor_id_of("zz")), Vendor::other);
  for (auto v : {Vendor::fast_dds, Vendor::cyclone_dds, Vendor::rti_connext, Vendor::opendds, Vendor::other})
    EXPECT_EQ(parse_vendor(to_string(v)), v);
}

// ---- the description document ----------------------------------------------------------

TEST(DescriptionModel, RoundTripsWhatTheDaemonServes) {
  const auto doc = nlohmann::json::parse(R"json({
    "streams": [
      {"name": "Depth", "type": "depth", "sensor-name": "Stereo Module",
       "profiles": [{"fps": 30, "format": "16UC1", "width": 848, "height": 480}],
       "default-profile": {"fps": 30, "format": "16UC1", "width": 848, "height": 480},
       "metadata-enabled": true,
       "options": [{"name": "Exposure", "value": 8500, "min": 1, "max": 165000, "step": 1, "default": 8500,
                    "description": "Depth Exposure (usec)",
                    "json": ["Exposure", 8500, 1, 165000, 1, 8500, "Depth Exposure (usec)"]}],
       "intrinsics": {"width": 848, "height": 480}},
      {"name": "Motion", "type": "motion", "sensor-name": "Motion Module", "profiles": [{"fps": 200}],
       "default-profile": null, "metadata-enabled": false, "options": []}],
    "device-options": [{"name": "Laser Power", "json": ["Laser Power", 150]}],
    "extrinsics": [{"from": "Depth", "to": "Color", "rotation": [1, 0, 0, 0, 1, 0, 0, 0, 1],
                    "translation": [0.015, 0, 0]}],
    "presets": ["Default"]})json");
  const auto d = rsd::model::description_from_json(doc);
  ASSERT_EQ(d.streams.size(), 2u);
  EXPECT_EQ(d.streams[0].sensor_name, "Stereo Module");
  EXPECT_EQ(d.streams[0].profiles[0].width, 848);
  EXPECT_FALSE(d.streams[1].default_profile);
  EXPECT_FALSE(d.streams[1].profiles[0].format);
  EXPECT_EQ(d.streams[0].options[0].default_value, 8500);
  EXPECT_EQ(rsd::model::to_json(d), doc);
}

TEST(DescriptionModel, MalformedDocumentsAreNamed) {
  for (const char* bad : {R"([])", R"({"streams": []})",
                          R"({"streams": [{"name": "x"}], "device-options": [], "extrinsics": [], "presets": []})",
                          R"({"streams": [], "device-options": [], "presets": [],
                              "extrinsics": [{"from": "a", "to": "b", "rotation": [1], "translation": [0, 0, 0]}]})"}) {
    EXPECT_THROW(rsd::model::description_from_json(nlohmann::json::parse(bad)), rsd::model::MalformedDocument) << bad;
  }
}
