// The keys of the daemon's device documents and of its list, and what the value of
// each is for: the tables device_list.cpp's reader looks each key up in.
#pragma once

#include "rsd_model/spelling.hpp"

#include <array>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>

namespace rsdiscovery::detail::device_keys {

namespace key = rsd::model::key;
namespace part_key = rsd::model::part_key;

// What the value of a key is for, in the object the key is in.
enum class Slot : std::uint8_t {
  ignored,  // a key this library does not read: its value is passed over
  refused,  // a key that an object the daemon owns does not have: the object is not taken
  // a device's
  id, source, sources, domain, topic_root, name, serial, product_line, product_id, fw_version, recovery,
  first_seen, last_seen, server, usb, warnings, host, in_use,
  // "server"'s
  participant_guid, participant_name, server_addresses, writer_guid,
  // "usb"'s
  bus, address, port_path, speed, vid_pid, speed_mbps, usb_text, device_nodes,
  // "host"'s
  host_name, host_addresses, host_guid,
  // "in-use"'s
  clients, streaming,
  // the list's
  devices, generation, complete,
};

struct KeySlot {
  std::string_view key;
  Slot slot;
};

// Each table in the order of its keys, the order the daemon writes them in (sorted):
// a key is looked for from where the last one was found (slot_of).
inline constexpr std::array kDeviceKeys{
    KeySlot{key::domain, Slot::domain},
    KeySlot{key::first_seen, Slot::first_seen},
    KeySlot{key::fw_version, Slot::fw_version},
    KeySlot{key::host, Slot::host},
    KeySlot{key::id, Slot::id},
    KeySlot{key::in_use, Slot::in_use},
    KeySlot{key::last_seen, Slot::last_seen},
    KeySlot{key::name, Slot::name},
    KeySlot{key::product_id, Slot::product_id},
    KeySlot{key::product_line, Slot::product_line},
    KeySlot{key::recovery, Slot::recovery},
    KeySlot{key::serial, Slot::serial},
    KeySlot{key::server, Slot::server},
    KeySlot{key::source, Slot::source},
    KeySlot{key::sources, Slot::sources},
    KeySlot{key::topic_root, Slot::topic_root},
    KeySlot{key::usb, Slot::usb},
    KeySlot{key::warnings, Slot::warnings},
};
inline constexpr std::array kServerKeys{
    KeySlot{part_key::addresses, Slot::server_addresses},
    KeySlot{part_key::participant_guid, Slot::participant_guid},
    KeySlot{part_key::participant_name, Slot::participant_name},
    KeySlot{part_key::writer_guid, Slot::writer_guid},
};
inline constexpr std::array kUsbKeys{
    KeySlot{part_key::address, Slot::address},
    KeySlot{part_key::bus, Slot::bus},
    KeySlot{key::device_nodes, Slot::device_nodes},
    KeySlot{part_key::pid, Slot::vid_pid},
    KeySlot{part_key::port_path, Slot::port_path},
    KeySlot{part_key::speed, Slot::speed},
    KeySlot{part_key::speed_mbps, Slot::speed_mbps},
    KeySlot{part_key::sysfs_path, Slot::usb_text},
    KeySlot{part_key::usb_version, Slot::usb_text},
    KeySlot{part_key::vid, Slot::vid_pid},
};
inline constexpr std::array kHostKeys{
    KeySlot{part_key::addresses, Slot::host_addresses},
    KeySlot{part_key::name, Slot::host_name},
    KeySlot{part_key::participant_guid, Slot::host_guid},
};
inline constexpr std::array kInUseKeys{
    KeySlot{part_key::clients, Slot::clients},
    KeySlot{part_key::streaming, Slot::streaming},
};
inline constexpr std::array kListKeys{
    KeySlot{"complete", Slot::complete},
    KeySlot{"devices", Slot::devices},
    KeySlot{"generation", Slot::generation},
};

// The slot of key `k`, looked for from `next` on (where the one after the last found
// stands), round to the start: read in the daemon's order, a key is found at once.
inline Slot slot_of(std::span<const KeySlot> keys, std::string_view k, Slot otherwise, std::uint8_t& next) {
  for (std::size_t n = 0, i = next; n < keys.size(); ++n, i = i + 1 == keys.size() ? 0 : i + 1) {
    const auto& ks = keys[i];
    // Length and first letter before memcmp: most keys are told apart by those.
    if (ks.key.size() == k.size() && !k.empty() && ks.key[0] == k[0] &&
        !std::memcmp(ks.key.data(), k.data(), k.size())) {
      next = static_cast<std::uint8_t>(i + 1 == keys.size() ? 0 : i + 1);
      return ks.slot;
    }
  }
  return otherwise;
}

}  // namespace rsdiscovery::detail::device_keys
