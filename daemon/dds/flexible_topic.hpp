// Creating realdds' `flexible` topics (device-info, and later notification) on
// Cyclone DDS safely: with no XTypes type information, and with the '-' that
// Cyclone older than 0.11 rejects in topic names.
#pragma once

#include <dds/dds.h>

namespace rsd::dds {

// realdds' flexible type as idlc generates it, minus the XTypes type information
// and mapping (and the flag that announces them).
//
// Why: a reader whose topic carries type information asks every peer with a
// different type id for its type object and parses the reply. Cyclone 0.10.2
// and 0.10.5 crash in that parser (SIGSEGV in ddsi_xt_type_init_impl) on the
// reply of a Cyclone 11 writer whose octets are declared as uint8 (measured
// with PyPI cyclonedds 11.0.1): one peer on the topic took the daemon down. A
// type object is untrusted input the daemon does not need: without type
// information Cyclone asks for none and matches endpoints by type name, as
// realdds (Fast DDS) peers do anyway.
const dds_topic_descriptor_t* flexible_descriptor();

// `generated` (an idlc descriptor) without its type information and mapping, for
// the same reason: the daemon's own topics (shared-usb) are read from any peer.
dds_topic_descriptor_t without_type_information(const dds_topic_descriptor_t& generated);

// dds_create_topic() of the flexible type under `name` (flexible_descriptor()).
dds_entity_t create_flexible_topic(dds_entity_t participant, const char* name, const dds_qos_t* qos);

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
