#include "dds/flexible_topic.hpp"

#include "flexible.h"

#include <cstdint>

#if RSD_CYCLONE_REJECTS_DASH
#include <algorithm>
#include <array>
#include <ctype.h>
#endif

namespace rsd::dds {

dds_topic_descriptor_t without_type_information(const dds_topic_descriptor_t& generated) {
  return dds_topic_descriptor_t{
      .m_size = generated.m_size,
      .m_align = generated.m_align,
      .m_flagset = generated.m_flagset & ~static_cast<std::uint32_t>(DDS_TOPIC_XTYPES_METADATA),
      .m_nkeys = generated.m_nkeys,
      .m_typename = generated.m_typename,
      .m_keys = generated.m_keys,
      .m_nops = generated.m_nops,
      .m_ops = generated.m_ops,
      .m_meta = generated.m_meta,
      .type_information = {nullptr, 0},
      .type_mapping = {nullptr, 0},
      .restrict_data_representation = generated.restrict_data_representation,
  };
}

const dds_topic_descriptor_t* flexible_descriptor() {
  static const dds_topic_descriptor_t without = without_type_information(realdds_topics_raw_flexible_desc);
  return &without;
}

dds_entity_t create_flexible_topic(dds_entity_t participant, const char* name, const dds_qos_t* qos) {
  return create_topic_allowing_dash(participant, flexible_descriptor(), name, qos);
}

dds_entity_t create_topic_allowing_dash(dds_entity_t participant,
                                        const dds_topic_descriptor_t* descriptor,
                                        const char* name, const dds_qos_t* qos) {
#if RSD_CYCLONE_REJECTS_DASH
  // glibc's table is indexed from -128 (EOF and signed chars) to 255.
  const unsigned short** table = __ctype_b_loc();
  const unsigned short* saved = *table;
  std::array<unsigned short, 384> patched{};
  std::copy(saved - 128, saved + 256, patched.begin());
  patched[128 + '-'] = static_cast<unsigned short>(patched[128 + '-'] | _ISalnum);
  *table = patched.data() + 128;
  const dds_entity_t topic = dds_create_topic(participant, descriptor, name, qos, nullptr);
  *table = saved;
  return topic;
#else
  return dds_create_topic(participant, descriptor, name, qos, nullptr);
#endif
}

}  // namespace rsd::dds
