// Reading Cyclone's built-in DCPSParticipant topic, shared by the two halves of
// DomainSession (domain_session.cpp identifies device-info writers by their
// participant; domain_participants.cpp follows the participants). Internal to dds/.
#pragma once

#include "dds/participant_book.hpp"

#include <dds/dds.h>

#include <array>
#include <cstddef>
#include <optional>

namespace rsd::dds {

// Every loaned read of the DCPSParticipant reader passes an array this long.
// Cyclone 0.10.2 fills as many pointers of the caller's array as its cached loan
// holds, which is the largest count any read of the reader asked for, not the
// count given (measured: a one-sample read after a 16-sample one wrote 15
// pointers past a one-element array, over the caller's stack; the daemon then
// aborted in free()). Kept one size, no read can overrun.
inline constexpr std::size_t kParticipantBatch = 16;
using ParticipantLoan = std::array<void*, kParticipantBatch>;

// A participant as DDS announced it (its SPDP, as Cyclone keeps it), read
// from the DCPSParticipant reader by instance; nothing if it is gone meanwhile.
std::optional<ParticipantSighting> read_participant(dds_entity_t reader, dds_instance_handle_t handle);

}  // namespace rsd::dds
