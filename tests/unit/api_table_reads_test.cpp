// The device routes over the typed table (ApiServer::answer, no socket): the list
// body spelled from the entries' text is byte for byte what dumping the whole
// document gives, the filters and lookups read the typed fields.
#include "api/api_server.hpp"
#include "api/format.hpp"

#include <gtest/gtest.h>

using nlohmann::json;

namespace {

class Sources final : public rsd::StatusView {
 public:
  bool done = true;
  std::vector<rsd::DomainStatus> domains() const override {
    rsd::DomainStatus d;
    d.domain = 1;
    d.complete = done;
    return {d};
  }
  std::vector<rsd::model::Participant> participants() const override { return {}; }
  std::optional<rsd::UsbStatus> usb() const override { return std::nullopt; }
  rsd::DeviceDescription describe(const std::string&) const override {
    return {rsd::DeviceDescription::Outcome::not_found, {}, "none"};
  }
};

struct Answer {
  int status = 0;
  std::string body;
};

Answer get(rsd::api::ApiServer& api, const std::string& target) {
  const auto raw = api.answer("GET " + target + " HTTP/1.1\r\nHost: localhost\r\n\r\n", false);
  const auto end = raw.find("\r\n\r\n");
  return {std::stoi(raw.substr(9, 3)), end == std::string::npos ? "" : raw.substr(end + 4)};
}

class ApiTableReads : public ::testing::Test {
 protected:
  void SetUp() override {
    table.upsert("dds-1-a", {{"source", "dds"}, {"domain", 1}, {"name", "Intel RealSense D455"},
                             {"serial", "111"}, {"product-line", "D400"}, {"topic-root", "realsense/D455_111"},
                             {"server", {{"addresses", {"10.0.0.1"}}}}, {"camera-own-key", {1, 2}}});
    table.upsert("dds-2-b", {{"source", "dds"}, {"domain", 2}, {"name", std::string("D555 \xff")},
                             {"serial", "222"}, {"product-line", "D500"}});
    table.upsert("usb-222", {{"source", "usb"}, {"name", "D555"}, {"serial", "222"}});  // merges into dds-2-b
    table.upsert("usb-9", {{"source", "usb"}, {"name", "Intel RealSense D435"}, {"serial", "999"}});
    table.upsert("usb-9b", {{"source", "usb"}, {"name", "Intel RealSense D435"}, {"serial", "999"}});
  }
  // What the list was before the table was typed: the whole document, dumped.
  std::string dumped(const std::vector<std::string>& ids) {
    json devices = json::array();
    for (const auto& id : ids) devices.push_back(*table.find(id));
    return rsd::api::dump({{"generation", table.generation()}, {"complete", sources.done}, {"devices", devices}}) +
           "\n";
  }
  rsd::SharedTable table;
  Sources sources;
  rsd::api::ApiServer api{table, sources, "test"};
};

}  // namespace

TEST_F(ApiTableReads, ListBodiesAreTheWholeDocumentDumped) {
  EXPECT_EQ(get(api, "/v1/devices").body, dumped({"dds-1-a", "dds-2-b", "usb-9", "usb-9b"}));
  EXPECT_EQ(get(api, "/v1/devices?domain=1").body, dumped({"dds-1-a"}));
  EXPECT_EQ(get(api, "/v1/devices?source=usb").body, dumped({"dds-2-b", "usb-9", "usb-9b"}));
  EXPECT_EQ(get(api, "/v1/devices?address=10.0.0.1&product-line=d400").body, dumped({"dds-1-a"}));
  EXPECT_EQ(get(api, "/v1/devices?name=d555").body, dumped({"dds-2-b"}));
  EXPECT_EQ(get(api, "/v1/devices?domain=3").body, dumped({}));
  sources.done = false;
  EXPECT_EQ(get(api, "/v1/devices?serial=999").body, dumped({"usb-9", "usb-9b"}));
}

TEST_F(ApiTableReads, LookupsReadTheTypedFields) {
  const auto by_id = get(api, "/v1/devices/dds-1-a");
  EXPECT_EQ(by_id.status, 200);
  EXPECT_EQ(by_id.body, rsd::api::dump(*table.find("dds-1-a")) + "\n");
  EXPECT_EQ(get(api, "/v1/devices/usb-222").body, get(api, "/v1/devices/dds-2-b").body);  // merged
  EXPECT_EQ(get(api, "/v1/devices/111").body, by_id.body);                  // serial
  EXPECT_EQ(get(api, "/v1/devices/realsense/D455_111").body, by_id.body);   // topic-root
  const auto two = get(api, "/v1/devices/999");
  EXPECT_EQ(two.status, 409);
  EXPECT_EQ(json::parse(two.body)["ids"], json::array({"usb-9", "usb-9b"}));
  EXPECT_EQ(get(api, "/v1/devices/nobody").status, 404);
}
