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
#include "dds/flexible_topic.hpp"

#include "flexible.h"

#include <dds/dds.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <random>
#include <string>
#include <thread>
#include <vector>

int main(int argc, char** argv) {
  const bool flood = argc == 5 && std::string(argv[2]) == "--flood";
  if (argc != 2 && !flood) {
    std::cerr << "usage: rsd-raw-writer DOMAIN [--flood COUNT RATE]\n";
    return 2;
  }
  const auto domain = static_cast<dds_domainid_t>(std::stoul(argv[1]));
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
