// The Camera Discovery set, assembled from notification messages. The fixture
// was captured from a real realdds 2.59 server (pyrealsense2's pyrealdds) with
// color, depth and motion streams, device options and extrinsics.
#include "dds/description.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

using rsd::dds::DescriptionAssembler;
using Step = DescriptionAssembler::Step;

namespace {

std::vector<nlohmann::json> captured() {
  std::ifstream in(std::string(RSD_TEST_DATA) + "/realdds-2.59-notifications.jsonl");
  std::vector<nlohmann::json> out;
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(nlohmann::json::parse(line));
  return out;
}

}  // namespace

TEST(Description, FromARealServersSet) {
  const auto messages = captured();
  ASSERT_EQ(messages.size(), 8u);
  DescriptionAssembler a;
  for (std::size_t i = 0; i < messages.size(); ++i) {
    EXPECT_EQ(a.add(messages[i]), "") << i;
    EXPECT_EQ(a.step(), i + 1 == messages.size() ? Step::complete : Step::partial) << i;
  }
  const auto d = a.description();
  ASSERT_EQ(d["streams"].size(), 3u);
  const auto& color = d["streams"][0];
  EXPECT_EQ(color["name"], "Color");
  EXPECT_EQ(color["type"], "color");
  EXPECT_EQ(color["sensor-name"], "RGB Camera");
  EXPECT_EQ(color["profiles"][1], (nlohmann::json{{"fps", 15}, {"format", "yuv422_yuy2"}, {"width", 1280}, {"height", 720}}));
  EXPECT_EQ(color["default-profile"], color["profiles"][1]);
  EXPECT_EQ(color["metadata-enabled"], false);
  EXPECT_EQ(color["options"][0]["name"], "Backlight Compensation");
  const auto& depth = d["streams"][1];
  EXPECT_EQ(depth["options"][0]["value"], 8500);
  EXPECT_EQ(depth["options"][0]["max"], 165000);
  EXPECT_EQ(depth["options"][0]["description"], "Depth Exposure (usec)");
  const auto& motion = d["streams"][2];
  EXPECT_EQ(motion["profiles"][0], (nlohmann::json{{"fps", 200}}));
  EXPECT_TRUE(motion.contains("intrinsics"));
  EXPECT_EQ(d["device-options"][0]["name"], "Device Option");
  ASSERT_EQ(d["extrinsics"].size(), 1u);
  EXPECT_EQ(d["extrinsics"][0]["from"], "Depth");
  EXPECT_EQ(d["extrinsics"][0]["to"], "Color");
  EXPECT_EQ(d["extrinsics"][0]["rotation"].size(), 9u);
  EXPECT_NEAR(d["extrinsics"][0]["translation"][0].get<double>(), 0.015, 1e-6);
}

TEST(Description, OtherNotificationsInterleavedAreIgnored) {
  const auto messages = captured();
  DescriptionAssembler a;
  for (const auto& m : messages) {
    a.add(m);
    EXPECT_EQ(a.add({{"id", "set-option"}, {"option-name", "Exposure"}, {"value", 1}}), "");
    EXPECT_EQ(a.add(nlohmann::json::array({1, 2})), "");
  }
  EXPECT_EQ(a.step(), Step::complete);
}

TEST(Description, ASecondSetStartsOverAndARepeatAfterCompleteIsHarmless) {
  const auto messages = captured();
  DescriptionAssembler a;
  for (std::size_t i = 0; i < 4; ++i) a.add(messages[i]);  // half a set
  for (const auto& m : messages) a.add(m);                  // another client's whole set
  EXPECT_EQ(a.step(), Step::complete);
  for (std::size_t i = 2; i < messages.size(); ++i) a.add(messages[i]);  // the tail again
  EXPECT_EQ(a.step(), Step::complete);
  EXPECT_EQ(a.description()["streams"].size(), 3u);
}

TEST(Description, ASetThatNeverCompletes) {
  const auto messages = captured();
  DescriptionAssembler a;
  EXPECT_EQ(a.stage(), "no device-header");
  // The stage after each message of the real set: what `ready-stage` says of a
  // camera whose set stops there.
  const std::vector<std::string> stages = {"device-header", "device-options", "stream 0 of 3", "stream 1 of 3",
                                           "stream 1 of 3", "stream 2 of 3", "stream 2 of 3"};
  for (std::size_t i = 0; i + 1 < messages.size(); ++i) {  // the last options never come
    a.add(messages[i]);
    EXPECT_EQ(a.stage(), stages[i]) << i;
  }
  EXPECT_EQ(a.step(), Step::partial);
  a.add(messages.back());
  EXPECT_EQ(a.stage(), "complete");
  DescriptionAssembler b;
  b.add(messages[2]);  // a stream-header before any device-header: not a set we follow
  EXPECT_EQ(b.step(), Step::waiting);
  EXPECT_EQ(b.stage(), "no device-header");
  DescriptionAssembler c;  // a server without device options
  c.add(messages[0]);
  c.add(messages[2]);
  EXPECT_EQ(c.stage(), "stream 0 of 3");
}

TEST(Description, MalformedMessagesAreRejectedByReason) {
  DescriptionAssembler a;
  EXPECT_EQ(a.add({{"id", "device-header"}, {"n-streams", "three"}}), "bad-device-header");
  EXPECT_EQ(a.add({{"id", "device-header"}, {"n-streams", 100000}}), "bad-device-header");
  EXPECT_EQ(a.add({{"id", "device-header"}, {"n-streams", 1}}), "");
  EXPECT_EQ(a.add({{"id", "stream-header"}, {"name", "Depth"}}), "bad-stream-header");
  EXPECT_EQ(a.add({{"id", "stream-header"}, {"name", "Depth"}, {"type", "depth"}, {"sensor-name", "S"},
                   {"profiles", {{"30", "z16"}}}}),
            "bad-stream-header");
  EXPECT_EQ(a.add({{"id", "stream-options"}, {"stream-name", "Nope"}, {"options", nlohmann::json::array()}}),
            "unknown-stream");
  EXPECT_EQ(a.add({{"id", "device-options"}, {"options", "lots"}}), "bad-device-options");
  EXPECT_EQ(a.add({{"id", "stream-header"}, {"name", "Depth"}, {"type", "depth"}, {"sensor-name", "S"},
                   {"profiles", {{30, "z16", 640, 480}}}, {"default-profile-index", 9}}),
            "");
  EXPECT_EQ(a.add({{"id", "stream-header"}, {"name", "Extra"}, {"type", "ir"}, {"sensor-name", "S"},
                   {"profiles", nlohmann::json::array()}}),
            "too-many-streams");
  EXPECT_EQ(a.add({{"id", "stream-options"}, {"stream-name", "Depth"}, {"options", nlohmann::json::array()}}), "");
  EXPECT_EQ(a.step(), Step::complete);
  EXPECT_TRUE(a.description()["streams"][0]["default-profile"].is_null());  // index out of range
}
