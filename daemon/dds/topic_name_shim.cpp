#include "dds/topic_name_shim.hpp"

#if RSD_CYCLONE_REJECTS_DASH
#include <algorithm>
#include <array>
#include <ctype.h>
#endif

namespace rsd::dds {

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
