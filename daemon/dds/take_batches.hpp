// Taking everything a Cyclone reader holds, on loan, a batch at a time: the one
// loop behind every listener of the DDS side (device-info, shared USB cameras,
// endpoints, a camera's notifications). Internal to dds/.
#pragma once

#include <dds/dds.h>

#include <array>
#include <cstddef>
#include <span>

namespace rsd::dds {

// Calls each_batch(samples, infos) for every batch dds_take gives, and returns the
// loan after it, whatever each_batch does (so it must not keep a sample). One batch
// size for every take of a reader, 16: Cyclone 0.10.2 fills as many pointers as its
// cached loan holds, not as many as asked (see kParticipantBatch), and a listener
// takes its lock per batch rather than for a whole flood.
template <class EachBatch>
void take_batches(dds_entity_t reader, EachBatch&& each_batch) {
  constexpr std::size_t kBatch = 16;
  std::array<void*, kBatch> samples{};
  std::array<dds_sample_info_t, kBatch> infos{};
  for (;;) {
    samples.fill(nullptr);
    const dds_return_t n = dds_take(reader, samples.data(), infos.data(), kBatch, kBatch);
    if (n <= 0) return;
    struct Loan {
      dds_entity_t reader;
      void** samples;
      dds_return_t n;
      ~Loan() { dds_return_loan(reader, samples, n); }
    } loan{reader, samples.data(), n};
    const auto count = static_cast<std::size_t>(n);
    each_batch(std::span<void* const>(samples.data(), count), std::span<const dds_sample_info_t>(infos.data(), count));
    if (count < kBatch) return;
  }
}

}  // namespace rsd::dds
