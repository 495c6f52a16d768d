// What the participant and endpoint book costs per tracked endpoint: heap in use
// (mallinfo2) after feeding a ParticipantBook the endpoints DCPSPublication and
// DCPSSubscription give, GUIDs and topic names as realdds spells them, for the book
// alone (no Cyclone, no table). Three worlds: realdds cameras with their clients
// (topics shared by a camera's server and clients), every endpoint on a topic of
// its own with a long name (the worst a peer can send within the topic-length cap),
// and a flood past the domain's caps (heap flat once they are reached).
// Run by hand: build/bench/rsd-bench-endpoint-memory
#include "dds/participant_book.hpp"

#include <malloc.h>

#include <cstdio>
#include <string>

namespace {

std::size_t heap_in_use() {
  malloc_trim(0);
  return mallinfo2().uordblks;
}

// Participant n's GUID as Cyclone prints it, and its endpoint k's (same prefix).
std::string participant(int n) {
  char guid[40];
  std::snprintf(guid, sizeof guid, "010f%04x.%08x.00000000.000001c1", n & 0xffff, n);
  return guid;
}
std::string endpoint(const std::string& participant, int k) {
  char tail[12];
  std::snprintf(tail, sizeof tail, "%08x", 0x100 + k);
  return participant.substr(0, 27) + tail;
}

// A realdds D555 server (one camera) and `clients` clients of it, each with a
// device (control writer, notification reader) and a Depth reader.
std::size_t realdds_camera(rsd::dds::ParticipantBook& book, int camera, int clients, int& next_participant) {
  const std::string root = "realsense/D555_" + std::to_string(555000000 + camera);
  const std::string server = participant(next_participant++);
  std::size_t n = 0;
  const auto add = [&](const std::string& p, int k, const std::string& topic, bool reader) {
    book.endpoint_alive(p, endpoint(p, k), topic, reader, "2026-12-05T00:00:00.000Z");
    ++n;
  };
  add(server, 1, "realsense/device-info", false);
  add(server, 2, root + "/notification", false);
  add(server, 3, root + "/control", true);
  add(server, 4, root + "/metadata", false);
  int k = 5;
  for (const char* stream : {"Depth", "Infrared 1", "Infrared 2", "Color", "Motion"})
    add(server, k++, "rt/" + root + "_" + stream, false);
  for (int c = 0; c < clients; ++c) {
    const std::string client = participant(next_participant++);
    add(client, 1, root + "/control", false);
    add(client, 2, root + "/notification", true);
    add(client, 3, "rt/" + root + "_Depth", true);
  }
  return n;
}

}  // namespace

int main() {
  const rsd::dds::EndpointLimits limits;
  std::printf("limits: %zu endpoints a participant, %zu a domain, topic names of %zu bytes, %zu topics\n",
              limits.per_participant, limits.per_domain, limits.topic_length, limits.topics);
  for (const int cameras : {100, 1000}) {
    const std::size_t before = heap_in_use();
    rsd::dds::ParticipantBook book;
    int next = 1;
    std::size_t endpoints = 0;
    for (int i = 0; i < cameras; ++i) endpoints += realdds_camera(book, i, 2, next);
    const std::size_t after = heap_in_use();
    std::printf("realdds: %4d cameras, 2 clients each: %zu endpoints on %zu topics, %zu B an endpoint\n", cameras,
                endpoints, book.endpoints().topics(), (after - before) / endpoints);
  }
  for (const std::size_t length : {64, 256}) {
    const std::size_t before = heap_in_use();
    rsd::dds::ParticipantBook book;
    const int n = 8000;  // within the topic cap: every name kept
    for (int i = 0; i < n; ++i) {
      const std::string p = participant(i / 16);
      std::string topic = "flood/" + std::to_string(i) + "/";
      topic.resize(length, 'x');
      book.endpoint_alive(p, endpoint(p, i % 16), topic, true, "2026-12-05T00:00:00.000Z");
    }
    const std::size_t after = heap_in_use();
    std::printf("a topic of its own, %3zu-byte names: %d endpoints, %zu B an endpoint\n", length, n,
                (after - before) / n);
  }
  // A flood of ever new endpoints and 256-byte topic names past every cap.
  rsd::dds::ParticipantBook book;
  const std::size_t base = heap_in_use();
  int i = 0;
  for (int round = 1; round <= 4; ++round) {
    for (const int end = i + 50000; i < end; ++i) {
      const std::string p = participant(i / 1000);
      std::string topic = "flood/" + std::to_string(i) + "/";
      topic.resize(256, 'x');
      book.endpoint_alive(p, endpoint(p, i % 1000), topic, true, "2026-12-05T00:00:00.000Z");
    }
    const auto& e = book.endpoints();
    std::printf("flood: %d endpoints offered: %zu kept, %zu topics, %llu refusals (domain and topic caps); heap %+ld KiB\n", i, e.total(),
                e.topics(),
                static_cast<unsigned long long>(e.refused(rsd::dds::EndpointRefusal::domain_limit) +
                                                e.refused(rsd::dds::EndpointRefusal::topic_limit)),
                static_cast<long>(heap_in_use() - base) / 1024);
  }
}
