// Parsing ros_discovery_info samples by hand, for both GID sizes (ros_nodes.hpp).
#include "dds/ros_nodes.hpp"

#include "dds/device_info.hpp"  // is_valid_utf8

#include <cstdint>
#include <cstdio>

namespace rsd::dds {
namespace {

// Plain CDR over the bytes after the encapsulation header, where alignment counts from.
class CdrReader {
 public:
  CdrReader(std::span<const unsigned char> data, bool little) : data_(data), little_(little) {}

  bool u32(std::uint32_t& out) {
    pos_ = (pos_ + 3) & ~std::size_t{3};
    if (!have(4)) return false;
    const unsigned char* p = data_.data() + pos_;
    out = little_ ? (std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24)
                  : (std::uint32_t{p[3]} | std::uint32_t{p[2]} << 8 | std::uint32_t{p[1]} << 16 | std::uint32_t{p[0]} << 24);
    pos_ += 4;
    return true;
  }
  // A bounded string: its length counts the NUL that ends it.
  bool text(std::string& out, std::size_t max) {
    std::uint32_t n = 0;
    if (!u32(n) || n == 0 || n > max + 1 || !have(n) || data_[pos_ + n - 1] != 0) return false;
    out.assign(reinterpret_cast<const char*>(data_.data() + pos_), n - 1);
    pos_ += n;
    return out.find('\0') == std::string::npos && is_valid_utf8(out);
  }
  std::span<const unsigned char> octets(std::size_t n) {
    if (!have(n)) return {};
    auto out = data_.subspan(pos_, n);
    pos_ += n;
    return out;
  }
  std::size_t left() const { return data_.size() - pos_; }

 private:
  bool have(std::size_t n) const { return pos_ <= data_.size() && data_.size() - pos_ >= n; }

  std::span<const unsigned char> data_;
  bool little_;
  std::size_t pos_ = 0;
};

constexpr std::size_t kNameBound = 256;  // string<=256 in rmw_dds_common's messages

std::optional<RosParticipantInfo> parse_with_gid(std::span<const unsigned char> body, bool little,
                                                 std::size_t gid_size, const RosInfoLimits& limits) {
  CdrReader in(body, little);
  // A GID's first 16 octets are the entity's DDS GUID; Humble pads it with zeros.
  const auto gid = [&](std::string& out) {
    auto g = in.octets(gid_size);
    if (g.size() != gid_size) return false;
    out = guid_text(g.first<16>());
    return true;
  };
  RosParticipantInfo info;
  std::uint32_t nodes = 0;
  if (!gid(info.participant) || !in.u32(nodes) || nodes > limits.nodes) return std::nullopt;
  std::size_t endpoints = 0;
  for (std::uint32_t i = 0; i < nodes; ++i) {
    std::string ns, name;
    if (!in.text(ns, kNameBound) || !in.text(name, kNameBound) || name.empty()) return std::nullopt;
    RosNode node{full_node_name(ns, name), {}};
    for (int list = 0; list < 2; ++list) {  // its readers, then its writers
      std::uint32_t n = 0;
      if (!in.u32(n) || n > limits.endpoints - endpoints || n > in.left() / gid_size) return std::nullopt;
      endpoints += n;
      for (std::uint32_t k = 0; k < n; ++k)
        if (!gid(node.endpoints.emplace_back())) return std::nullopt;
    }
    info.nodes.push_back(std::move(node));
  }
  // What is left is at most the padding to the next 4 octets; a sample read with
  // the wrong GID size ends early (or runs out) instead.
  if (in.left() >= 4) return std::nullopt;
  return info;
}

}  // namespace

std::optional<RosParticipantInfo> parse_ros_discovery_info(std::span<const unsigned char> sample,
                                                           const RosInfoLimits& limits) {
  if (sample.size() < 4 || sample.size() > limits.bytes) return std::nullopt;
  // The encapsulation kind, big-endian: CDR (0, 1) or XCDR2 plain (6, 7), the low
  // bit telling little-endian; the two layouts agree for these types.
  if (sample[0] != 0 || (sample[1] != 0 && sample[1] != 1 && sample[1] != 6 && sample[1] != 7)) return std::nullopt;
  const bool little = sample[1] & 1;
  const auto body = sample.subspan(4);
  if (auto iron = parse_with_gid(body, little, 16, limits)) return iron;
  return parse_with_gid(body, little, 24, limits);
}

std::string full_node_name(std::string_view node_namespace, std::string_view node_name) {
  // ROS 2 namespaces are absolute; one that is not is read as if it were, so a
  // name always begins with '/'.
  std::string out = node_namespace.starts_with('/') ? std::string(node_namespace) : "/" + std::string(node_namespace);
  if (out.back() != '/') out += '/';
  out += node_name;
  return out;
}

std::string guid_text(std::span<const unsigned char, 16> g) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%02x%02x%02x%02x.%02x%02x%02x%02x.%02x%02x%02x%02x.%02x%02x%02x%02x", g[0], g[1],
                g[2], g[3], g[4], g[5], g[6], g[7], g[8], g[9], g[10], g[11], g[12], g[13], g[14], g[15]);
  return buf;
}

}  // namespace rsd::dds
