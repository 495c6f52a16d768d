// Creating the realdds topic on Cyclone DDS older than 0.11.
#pragma once

#include <dds/dds.h>

namespace rsd::dds {

// dds_create_topic(), except that on Cyclone < 0.11 a '-' in `name` is accepted.
//
// Why: realdds' discovery topic is "realsense/device-info", and Cyclone 0.10
// (Debian bookworm) rejects '-' in topic names with "Bad Parameter", although
// the DDS spec's grammar allows it and 0.11 fixed the check. The check calls
// glibc's isalnum() on the calling thread, so for the length of this one call
// the thread's ctype table is pointed at a copy in which '-' is alphanumeric.
// Nothing else runs on this thread meanwhile; the table is restored before
// returning. On Cyclone >= 0.11 this is plain dds_create_topic().
dds_entity_t create_topic_allowing_dash(dds_entity_t participant,
                                        const dds_topic_descriptor_t* descriptor,
                                        const char* name, const dds_qos_t* qos);

}  // namespace rsd::dds
