// rsd-raw-writer: writes arbitrary realdds `flexible` samples on
// realsense/device-info with Cyclone DDS, for the bad-input and CBOR tests
// (pyrealdds validates JSON before sending, so it cannot send garbage).
//
//   rsd-raw-writer DOMAIN
// prints "matched" once a reader on the topic is matched, then reads lines
// "FORMAT HEX" (FORMAT: the data_format number, HEX: the payload in hex, "-"
// for none) from stdin, writes each as one sample and answers "ok" or "error ...".
#include "dds/flexible_topic.hpp"

#include "flexible.h"

#include <dds/dds.h>

#include <chrono>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: rsd-raw-writer DOMAIN\n";
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
