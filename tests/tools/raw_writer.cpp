// rsd-raw-writer: writes arbitrary realdds `flexible` samples on
// realsense/device-info with Cyclone DDS, for the bad-input and CBOR tests
// (pyrealdds validates JSON before sending, so it cannot send garbage).
//
//   rsd-raw-writer DOMAIN
// prints "matched" once a reader on the topic is matched, then reads lines
// "FORMAT HEX" (FORMAT: the data_format number, HEX: the payload in hex, "-"
// for none) from stdin, writes each as one sample and answers "ok" or "error ...".
//
//   rsd-raw-writer DOMAIN --flood COUNT RATE
// a rogue writer: once matched, writes COUNT valid device-infos, each with a
// random topic-root, at RATE messages per second, prints "flooded N SECONDS"
// and exits (its writer goes with it).
//
//   rsd-raw-writer DOMAIN --writers PARTICIPANTS WRITERS
// many writers: PARTICIPANTS participants of WRITERS device-info writers each,
// every writer announcing one camera (topic-root realsense/many_P_W) as realdds
// does, once per reader that matches it; prints "announced N" once every writer
// has announced to some reader, then runs until stdin closes.
//
//   rsd-raw-writer DOMAIN --endpoints PARTICIPANTS READERS NAME_LENGTH
// an endpoint flood: PARTICIPANTS participants of READERS readers each, every reader
// on a topic of its own whose name is NAME_LENGTH bytes long; prints "created N
// SECONDS" once all are made, then runs until stdin closes (and deletes them).
#include "dds/flexible_topic.hpp"

#include "flexible.h"

#include <dds/dds.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace {

dds_qos_t* device_info_qos() {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  return qos;
}

void write_json(dds_entity_t writer, const std::string& text) {
  realdds_topics_raw_flexible msg{};
  msg.data_format = realdds_topics_raw_FLEXIBLE_DATA_JSON;
  msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(text.size());
  msg.data._buffer = reinterpret_cast<std::uint8_t*>(const_cast<char*>(text.data()));
  msg.data._release = false;
  dds_write(writer, &msg);
}

// --writers: every writer writes its camera on each new match (total_count grew),
// the way a realdds server's device writers do; the waitset wakes on matches.
int many_writers(dds_domainid_t domain, int participants, int per_participant) {
  struct Announcer {
    dds_entity_t writer;
    std::string text;
    std::uint32_t matches_seen = 0;
  };
  std::vector<Announcer> announcers;
  std::vector<dds_entity_t> made;
  for (int p = 0; p < participants; ++p) {
    dds_qos_t* pqos = dds_create_qos();
    dds_qset_entity_name(pqos, ("rsd-many-writers-" + std::to_string(p)).c_str());
    const dds_entity_t participant = dds_create_participant(domain, pqos, nullptr);
    dds_delete_qos(pqos);
    dds_qos_t* qos = device_info_qos();
    const dds_entity_t topic = rsd::dds::create_topic_allowing_dash(
        participant, &realdds_topics_raw_flexible_desc, "realsense/device-info", qos);
    if (participant < 0 || topic < 0) {
      std::cerr << "cannot create participant " << p << "\n";
      return 1;
    }
    made.push_back(participant);
    for (int w = 0; w < per_participant; ++w) {
      const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
      if (writer < 0) {
        std::cerr << "cannot create writer " << w << " of participant " << p << "\n";
        return 1;
      }
      dds_set_status_mask(writer, DDS_PUBLICATION_MATCHED_STATUS);
      const std::string serial = std::to_string(p) + "_" + std::to_string(w);
      announcers.push_back({writer, R"({"name":"Intel RealSense D455","serial":")" + serial +
                                        R"(","product-line":"D400","topic-root":"realsense/many_)" + serial + R"("})"});
    }
    dds_delete_qos(qos);
  }
  const dds_entity_t waitset = dds_create_waitset(made.front());
  for (const auto& a : announcers) dds_waitset_attach(waitset, a.writer, a.writer);
  // stdin closing ends the run: a thread waits for it and wakes the waitset.
  const dds_entity_t done = dds_create_guardcondition(made.front());
  dds_waitset_attach(waitset, done, done);
  std::thread([done] {
    std::string line;
    while (std::getline(std::cin, line)) {}
    dds_set_guardcondition(done, true);
  }).detach();
  bool told = false;
  std::vector<dds_attach_t> woken(64);
  for (;;) {
    dds_waitset_wait(waitset, woken.data(), woken.size(), DDS_SECS(1));
    bool quit = false;
    dds_read_guardcondition(done, &quit);
    if (quit) break;
    std::size_t announced = 0;
    for (auto& a : announcers) {
      dds_publication_matched_status_t st{};
      dds_get_publication_matched_status(a.writer, &st);  // also resets the status, so the waitset rests
      if (st.total_count > a.matches_seen && st.current_count > 0) write_json(a.writer, a.text);
      a.matches_seen = st.total_count;
      announced += a.matches_seen > 0;
    }
    if (!told && announced == announcers.size()) {
      std::cout << "announced " << announced << std::endl;
      told = true;
    }
  }
  for (const auto participant : made) dds_delete(participant);
  return 0;
}

int many_endpoints(dds_domainid_t domain, int participants, int per_participant, std::size_t name_length) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<dds_entity_t> made;
  long created = 0;
  for (int p = 0; p < participants; ++p) {
    dds_qos_t* pqos = dds_create_qos();
    dds_qset_entity_name(pqos, ("rsd-endpoint-flood-" + std::to_string(p)).c_str());
    const dds_entity_t participant = dds_create_participant(domain, pqos, nullptr);
    dds_delete_qos(pqos);
    if (participant < 0) {
      std::cerr << "cannot create participant " << p << "\n";
      return 1;
    }
    made.push_back(participant);
    for (int r = 0; r < per_participant; ++r) {
      std::string name = "rsd/flood_" + std::to_string(p) + "_" + std::to_string(r) + "_";
      name.resize(std::max(name.size(), name_length), 'x');
      const dds_entity_t topic = dds_create_topic(participant, &realdds_topics_raw_flexible_desc, name.c_str(),
                                                  nullptr, nullptr);
      if (topic < 0 || dds_create_reader(participant, topic, nullptr, nullptr) < 0) {
        std::cerr << "cannot create reader " << r << " of participant " << p << "\n";
        return 1;
      }
      ++created;
    }
  }
  const std::chrono::duration<double> took = std::chrono::steady_clock::now() - start;
  std::cout << "created " << created << " " << took.count() << std::endl;
  std::string line;
  while (std::getline(std::cin, line)) {}
  for (const auto participant : made) dds_delete(participant);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const bool flood = argc == 5 && std::string(argv[2]) == "--flood";
  const bool writers = argc == 5 && std::string(argv[2]) == "--writers";
  const bool endpoints = argc == 6 && std::string(argv[2]) == "--endpoints";
  if (argc != 2 && !flood && !writers && !endpoints) {
    std::cerr << "usage: rsd-raw-writer DOMAIN [--flood COUNT RATE | --writers PARTICIPANTS WRITERS |\n"
                 "                             --endpoints PARTICIPANTS READERS NAME_LENGTH]\n";
    return 2;
  }
  const auto domain = static_cast<dds_domainid_t>(std::stoul(argv[1]));
  if (writers) return many_writers(domain, std::stoi(argv[3]), std::stoi(argv[4]));
  if (endpoints)
    return many_endpoints(domain, std::stoi(argv[3]), std::stoi(argv[4]), std::stoul(argv[5]));
  dds_qos_t* pqos = dds_create_qos();
  dds_qset_entity_name(pqos, "rsd-raw-writer");
  const dds_entity_t participant = dds_create_participant(domain, pqos, nullptr);
  dds_delete_qos(pqos);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  const dds_entity_t topic = rsd::dds::create_topic_allowing_dash(
      participant, &realdds_topics_raw_flexible_desc, "realsense/device-info", qos);
  const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (participant < 0 || topic < 0 || writer < 0) {
    std::cerr << "cannot create the DDS writer\n";
    return 1;
  }
  // Blocks on the DDS wait-set, not a timer: returns when a reader matches.
  dds_set_status_mask(writer, DDS_PUBLICATION_MATCHED_STATUS);
  const dds_entity_t waitset = dds_create_waitset(participant);
  dds_waitset_attach(waitset, writer, writer);
  for (;;) {
    dds_publication_matched_status_t st{};
    dds_get_publication_matched_status(writer, &st);
    if (st.current_count > 0) break;
    if (dds_waitset_wait(waitset, nullptr, 0, DDS_SECS(30)) == 0) {
      std::cerr << "no reader matched within 30 s\n";
      return 1;
    }
  }
  std::cout << "matched" << std::endl;

  if (flood) {
    const long count = std::stol(argv[3]);
    const double rate = std::stod(argv[4]);
    std::mt19937_64 random(std::random_device{}());
    const auto start = std::chrono::steady_clock::now();
    for (long i = 0; i < count; ++i) {
      if (i % 100 == 0)  // paced in batches: a sleep per message would be too coarse
        std::this_thread::sleep_until(start + std::chrono::duration<double>(static_cast<double>(i) / rate));
      char text[160];
      const auto r = random();
      const int len = std::snprintf(text, sizeof text,
                                    R"({"name":"Rogue","serial":"%016llx","topic-root":"realsense/rogue_%016llx"})",
                                    static_cast<unsigned long long>(r), static_cast<unsigned long long>(r));
      realdds_topics_raw_flexible msg{};
      msg.data_format = realdds_topics_raw_FLEXIBLE_DATA_JSON;
      msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(len);
      msg.data._buffer = reinterpret_cast<std::uint8_t*>(text);
      msg.data._release = false;
      dds_write(writer, &msg);
    }
    const std::chrono::duration<double> took = std::chrono::steady_clock::now() - start;
    std::cout << "flooded " << count << " " << took.count() << std::endl;
    dds_delete(participant);
    return 0;
  }

  std::string line;
  while (std::getline(std::cin, line)) {
    const auto space = line.find(' ');
    if (space == std::string::npos) {
      std::cout << "error expected 'FORMAT HEX'" << std::endl;
      continue;
    }
    const int format = std::stoi(line.substr(0, space));
    const std::string hex = line.substr(space + 1);
    std::vector<std::uint8_t> bytes;
    if (hex != "-")
      for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
        bytes.push_back(static_cast<std::uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
    realdds_topics_raw_flexible msg{};
    msg.data_format = static_cast<realdds_topics_raw_flexible_data_format>(format);
    msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(bytes.size());
    msg.data._buffer = bytes.data();
    msg.data._release = false;
    const dds_return_t rc = dds_write(writer, &msg);
    if (rc < 0) std::cout << "error " << dds_strretcode(rc) << std::endl;
    else std::cout << "ok" << std::endl;
  }
  dds_delete(participant);
  return 0;
}
