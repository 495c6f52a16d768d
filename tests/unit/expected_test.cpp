// Expected cameras, the pure parts: the configuration's forms (flag and file), which
// are listed in a table, and the document's round trip.
#include "config/config.hpp"
#include "table/expected.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

namespace {

// With an empty file of its own: the host's /etc/rs-discoveryd/config.json is no test's.
rsd::Config parse(std::vector<const char*> args) {
  static const std::string empty = [] {
    const std::string path = testing::TempDir() + "rsd-expected-test.json";
    std::ofstream(path) << "{}";
    return path;
  }();
  args.insert(args.begin(), "rs-discoveryd");
  args.push_back("--config");
  args.push_back(empty.c_str());
  return rsd::parse_command_line(static_cast<int>(args.size()), args.data()).config;
}

}  // namespace

TEST(Expected, FlagNamesASerialOrATopicRoot) {
  std::string error;
  const auto serial = rsd::model::parse_expected("front=123456", &error);
  ASSERT_TRUE(serial) << error;
  EXPECT_EQ(serial->name, "front");
  EXPECT_EQ(serial->serial, "123456");
  EXPECT_TRUE(serial->topic_root.empty());
  const auto root = rsd::model::parse_expected("realsense/D555_1", &error);
  ASSERT_TRUE(root) << error;
  EXPECT_EQ(root->name, "");
  EXPECT_EQ(root->topic_root, "realsense/D555_1");
  EXPECT_EQ(rsd::model::describe(*serial), "front (123456)");
  for (const char* bad : {"", "front=", "=123", "a b=1", "front=12 34", "x=y=z"})
    EXPECT_FALSE(rsd::model::parse_expected(bad, &error)) << bad;
}

TEST(Expected, FileTakesStringsAndObjects) {
  std::string error;
  EXPECT_TRUE(rsd::model::expected_from_json(nlohmann::json{{"topic-root", "realsense/D_1"}, {"name", "wrist"}},
                                             &error));
  EXPECT_FALSE(rsd::model::expected_from_json(nlohmann::json{{"serial", "1"}, {"topic-root", "r/1"}}, &error));
  EXPECT_FALSE(rsd::model::expected_from_json(nlohmann::json{{"serial", "1"}, {"nmae", "x"}}, &error));
  EXPECT_FALSE(rsd::model::expected_from_json(nlohmann::json(5), &error));
}

TEST(Expected, ConfigKeyFlagsRepeatAndTwiceIsAnError) {
  const auto c = parse({"--expect", "front=1", "--expect", "realsense/D555_2"});
  ASSERT_EQ(c.expect.size(), 2u);
  EXPECT_EQ(c.expect[1].topic_root, "realsense/D555_2");
  EXPECT_THROW(parse({"--expect", "front=1", "--expect", "back=1"}), rsd::ConfigError);
  EXPECT_THROW(parse({"--expect", "front=1", "--expect", "front=2"}), rsd::ConfigError);
  rsd::Config file;
  rsd::apply_config_json(R"({"expect": ["1", {"serial": "2", "name": "b"}]})", file);
  EXPECT_EQ(file.expect.size(), 2u);
  EXPECT_THROW(rsd::apply_config_json(R"({"expect": "1"})", file), rsd::ConfigError);
}

TEST(Expected, ListedBySerialOrTopicRoot) {
  rsd::DeviceTable table;
  table.upsert("dds-0-a", {{"source", "dds"}, {"name", "A"}, {"serial", "1"}, {"topic-root", "realsense/A_1"}},
               "2026-01-01T00:00:00.000Z");
  const std::vector<rsd::model::ExpectedCamera> expected = {
      {"front", "1", ""}, {"top", "", "realsense/A_1"}, {"wrist", "2", ""}};
  const auto report = rsd::expected_report(expected, table.entries(), true);
  ASSERT_EQ(report.present.size(), 2u);
  EXPECT_EQ(report.present[0].id, "dds-0-a");
  ASSERT_EQ(report.missing.size(), 1u);
  EXPECT_EQ(report.missing[0].camera.name, "wrist");
  const auto doc = rsd::model::to_json(report);
  EXPECT_EQ(doc["expected"], 3);
  EXPECT_EQ(doc["present"].size(), 2u);
  EXPECT_EQ(doc["missing"][0], nlohmann::json({{"name", "wrist"}, {"serial", "2"}}));
}
