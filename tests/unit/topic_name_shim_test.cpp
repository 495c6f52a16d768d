// The one place the daemon bends Cyclone DDS 0.10: a '-' in the realdds topic
// name. It must create the topic, and leave the thread's ctype table as it was.
#include "dds/topic_name_shim.hpp"

#include "flexible.h"

#include <gtest/gtest.h>

#include <cctype>

namespace {
// Domain 232 is kept out of the test fixtures' pool (tests/conftest.py), so this
// participant never meets another test's.
constexpr dds_domainid_t kDomain = 232;
}  // namespace

TEST(TopicNameShim, CreatesTheRealddsTopicAndRestoresCtype) {
  const dds_entity_t participant = dds_create_participant(kDomain, nullptr, nullptr);
  ASSERT_GT(participant, 0);
  const dds_entity_t topic = rsd::dds::create_topic_allowing_dash(
      participant, &realdds_topics_raw_flexible_desc, "realsense/device-info", nullptr);
  EXPECT_GT(topic, 0) << dds_strretcode(topic);
  char name[64] = {};
  ASSERT_GE(dds_get_name(topic, name, sizeof name), 0);
  EXPECT_STREQ(name, "realsense/device-info");
  char type[64] = {};
  ASSERT_GE(dds_get_type_name(topic, type, sizeof type), 0);
  EXPECT_STREQ(type, "realdds::topics::raw::flexible");  // must match realdds exactly
  EXPECT_FALSE(std::isalnum('-'));  // the table is back to glibc's
  EXPECT_TRUE(std::isalnum('a'));
  EXPECT_FALSE(std::isalnum(' '));
  dds_delete(participant);
}

TEST(TopicNameShim, StillRejectsWhatIsReallyInvalid) {
  const dds_entity_t participant = dds_create_participant(kDomain, nullptr, nullptr);
  ASSERT_GT(participant, 0);
  EXPECT_LT(rsd::dds::create_topic_allowing_dash(participant, &realdds_topics_raw_flexible_desc,
                                                 "has space", nullptr),
            0);
  dds_delete(participant);
}
