#include "dds/device_info.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using namespace rsd::dds;
using nlohmann::json;

namespace {
std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

Parsed parse_json_text(const std::string& text) {
  auto b = bytes(text);
  return parse_device_info(0, b);
}

std::string reason(const Parsed& p) {
  if (auto* r = std::get_if<Rejected>(&p)) return r->reason;
  return "accepted";
}
}  // namespace

TEST(DeviceInfo, AcceptsRealddsJsonAndKeepsEveryField) {
  auto p = parse_json_text(
      R"({"name":"Intel RealSense D455","serial":"123622270732","product-line":"D400",)"
      R"("product-id":"0B5C","fw-version":"5.16.0.1","topic-root":"realsense/D455_123622270732","extra":{"a":1}})");
  auto* info = std::get_if<DeviceInfo>(&p);
  ASSERT_NE(info, nullptr) << reason(p);
  EXPECT_EQ(info->topic_root, "realsense/D455_123622270732");
  EXPECT_EQ(info->fields["fw-version"], "5.16.0.1");
  EXPECT_EQ(info->fields["extra"]["a"], 1);
}

TEST(DeviceInfo, ForgivesTrailingNulTerminator) {
  auto p = parse_json_text(std::string("{\"name\":\"x\",\"topic-root\":\"r\"}\0", 30));
  EXPECT_EQ(reason(p), "accepted");
}

TEST(DeviceInfo, AcceptsCbor) {
  json doc = {{"name", "Intel RealSense D405"}, {"topic-root", "realsense/D405_1"}, {"serial", "1"}};
  auto cbor = json::to_cbor(doc);
  auto p = parse_device_info(1, cbor);
  auto* info = std::get_if<DeviceInfo>(&p);
  ASSERT_NE(info, nullptr) << reason(p);
  EXPECT_EQ(info->fields, doc);
}

TEST(DeviceInfo, StoppingNeedsOnlyTopicRootAndAnyValue) {
  for (const char* text : {R"({"topic-root":"realsense/D455_1","stopping":true})",
                           R"({"topic-root":"realsense/D455_1","stopping":0})",
                           R"({"topic-root":"realsense/D455_1","stopping":null,"name":"x"})"}) {
    auto p = parse_json_text(text);
    auto* stop = std::get_if<Stopping>(&p);
    ASSERT_NE(stop, nullptr) << text;
    EXPECT_EQ(stop->topic_root, "realsense/D455_1");
  }
}

TEST(DeviceInfo, RejectsEachKindOfBadInputWithItsReason) {
  struct Case {
    std::int32_t format;
    std::string data;
    const char* reason;
  };
  const std::vector<Case> cases = {
      {0, "not json", "not-json"},
      {0, "{\"name\":\"x\"", "not-json"},
      {0, std::string("{\"name\":\"x\",\0\"topic-root\":\"r\"}", 30), "not-json"},
      {0, "[1,2]", "not-object"},
      {0, "42", "not-object"},
      {0, R"({"topic-root":"r"})", "missing-name"},
      {0, R"({"topic-root":"r","name":""})", "missing-name"},
      {0, R"({"topic-root":"r","name":7})", "missing-name"},
      {0, R"({"name":"x"})", "missing-topic-root"},
      {0, R"({"name":"x","topic-root":{}})", "missing-topic-root"},
      {0, "{\"name\":\"\xc3\x28\",\"topic-root\":\"r\"}", "invalid-utf8"},
      {0, "{\"name\":\"\xed\xa0\x80\",\"topic-root\":\"r\"}", "invalid-utf8"},  // surrogate
      {0, "{\"name\":\"\xc0\xaf\",\"topic-root\":\"r\"}", "invalid-utf8"},      // overlong
      {0, std::string(2000, '[') + std::string(2000, ']'), "too-deep"},
      {0, std::string(4096, ' '), "too-large"},
      {0, "", "empty"},
      {1, "\xff\x01", "bad-cbor"},
      {1, std::string(3000, '\x81') + std::string(1, '\0'), "too-deep"},
      {2, R"({"name":"x","topic-root":"r"})", "custom-format"},
      {-1, R"({"name":"x","topic-root":"r"})", "unknown-format"},
      {3, R"({"name":"x","topic-root":"r"})", "unknown-format"},
  };
  for (const auto& c : cases) {
    auto b = bytes(c.data);
    EXPECT_EQ(reason(parse_device_info(c.format, b)), c.reason) << c.data.substr(0, 40);
  }
}

TEST(DeviceInfo, CborWithInvalidUtf8TextIsRejected) {
  // {"name": <text "\xc3\x28">, "topic-root": "r"} built by hand: nlohmann would refuse to encode it.
  std::vector<std::uint8_t> cbor = {0xA2, 0x64, 'n', 'a', 'm', 'e', 0x62, 0xC3, 0x28,
                                    0x6A, 't', 'o', 'p', 'i', 'c', '-', 'r', 'o', 'o', 't', 0x61, 'r'};
  EXPECT_EQ(reason(parse_device_info(1, cbor)), "invalid-utf8");
}

// Regression (found by fuzz_device_info): a CBOR array header claiming an
// enormous length made nlohmann throw out_of_range out of the parser, which on
// a DDS listener thread would have terminated the daemon.
TEST(DeviceInfo, CborArrayWithEnormousLengthIsRejectedNotThrown) {
  std::vector<std::uint8_t> cbor = {0x9B, 0x63, 0x61, 0x62, 0x63, 0x61, 0x62, 0x63, 0x61, 0x00};
  EXPECT_EQ(reason(parse_device_info(1, cbor)), "bad-cbor");
  std::vector<std::uint8_t> map = {0xBB, 0x7F, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};
  EXPECT_EQ(reason(parse_device_info(1, map)), "bad-cbor");
}

TEST(DeviceInfo, EveryReasonIsDocumented) {
  auto b = bytes("nope");
  const std::string r = reason(parse_device_info(0, b));
  bool found = false;
  for (const char* known : kRejectReasons) found = found || r == known;
  EXPECT_TRUE(found);
}

TEST(DeviceId, IsUrlSafeAndInjective) {
  EXPECT_EQ(device_id(0, "realsense/D455_123622270732"), "dds-0-realsense.D455_123622270732");
  EXPECT_EQ(device_id(7, "a.b"), "dds-7-a~2Eb");
  EXPECT_NE(device_id(0, "a/b"), device_id(0, "a.b"));
  EXPECT_NE(device_id(1, "x"), device_id(11, "x"));
  EXPECT_EQ(device_id(0, "a b?~"), "dds-0-a~20b~3F~7E");
  for (char c : device_id(3, "realsense/\xe2\x82\xac %/#?&"))
    EXPECT_TRUE(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == '~')
        << c;
}

TEST(Utf8, Validation) {
  EXPECT_TRUE(is_valid_utf8("plain"));
  EXPECT_TRUE(is_valid_utf8("\xe2\x82\xac\xf0\x9f\x98\x80"));
  EXPECT_FALSE(is_valid_utf8("\xe2\x82"));
  EXPECT_FALSE(is_valid_utf8("\xf4\x90\x80\x80"));  // past U+10FFFF
}
