// Where the daemon bends Cyclone DDS: a '-' in the realdds topic name (it must
// create the topic and leave the thread's ctype table as it was), and a type
// without XTypes information (so no peer's type object is ever asked for).
#include "dds/flexible_topic.hpp"

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

TEST(FlexibleTopic, CarriesNoTypeInformationButTheSameTypeName) {
  const dds_topic_descriptor_t* d = rsd::dds::flexible_descriptor();
  EXPECT_EQ(d->m_flagset & DDS_TOPIC_XTYPES_METADATA, 0u);
  EXPECT_EQ(d->type_information.sz, 0u);
  EXPECT_EQ(d->type_mapping.sz, 0u);
  // idlc's own descriptor does carry it: the daemon must not use that one.
  EXPECT_NE(realdds_topics_raw_flexible_desc.m_flagset & DDS_TOPIC_XTYPES_METADATA, 0u);
  EXPECT_STREQ(d->m_typename, realdds_topics_raw_flexible_desc.m_typename);
  EXPECT_EQ(d->m_ops, realdds_topics_raw_flexible_desc.m_ops);  // same wire layout

  const dds_entity_t participant = dds_create_participant(kDomain, nullptr, nullptr);
  ASSERT_GT(participant, 0);
  const dds_entity_t topic = rsd::dds::create_flexible_topic(participant, "realsense/device-info", nullptr);
  ASSERT_GT(topic, 0) << dds_strretcode(topic);
  dds_typeinfo_t* info = nullptr;
  EXPECT_LT(dds_get_typeinfo(topic, &info), 0);  // nothing to announce, nothing to look up
  if (info) dds_free_typeinfo(info);
  dds_delete(participant);
}
