// HostProbe's sockets and the neighbour table read (host_probe.hpp).
#include "net/host_probe.hpp"

#include <arpa/inet.h>
#include <linux/neighbour.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace rsd::net {

namespace {

constexpr std::uint16_t kDiscardPort = 9;  // nothing listens there: a live kernel refuses it

int open_probe(std::uint32_t address) {
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return -1;
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(kDiscardPort);
  to.sin_addr.s_addr = address;
  // Connected, so the kernel hands this socket the ICMP errors that come back.
  if (connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) < 0 && errno != ENETUNREACH &&
      errno != EHOSTUNREACH) {
    close(fd);
    return -1;
  }
  return fd;
}

// The error the socket has, from the last send or an ICMP answer since.
int socket_error(int fd, bool send_now) {
  if (send_now) {
    const char byte = 0;
    if (send(fd, &byte, 1, MSG_DONTWAIT | MSG_NOSIGNAL) < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return errno;
  }
  char buf[16];
  if (recv(fd, buf, sizeof buf, MSG_DONTWAIT) < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return errno;
  return 0;
}

}  // namespace

HostProbe::HostProbe(const std::vector<std::string>& addresses, Clock::time_point now,
                     std::chrono::milliseconds give_up_after)
    : started_(now), next_send_(now), give_up_after_(give_up_after) {
  for (const auto& text : addresses) {
    in_addr a{};
    if (inet_pton(AF_INET, text.c_str(), &a) != 1) continue;
    const int fd = open_probe(a.s_addr);
    if (fd >= 0) targets_.push_back({a.s_addr, fd, std::nullopt});
  }
}

HostProbe::HostProbe(HostProbe&& other) noexcept
    : targets_(std::move(other.targets_)),
      started_(other.started_),
      next_send_(other.next_send_),
      give_up_after_(other.give_up_after_) {
  other.targets_.clear();
}

HostProbe& HostProbe::operator=(HostProbe&& other) noexcept {
  std::swap(targets_, other.targets_);  // other closes what this held
  started_ = other.started_;
  next_send_ = other.next_send_;
  give_up_after_ = other.give_up_after_;
  return *this;
}

HostProbe::~HostProbe() {
  for (const auto& t : targets_) close(t.fd);
}

std::optional<model::HostVerdict> HostProbe::poll(Clock::time_point now) {
  const bool send_now = now >= next_send_;
  if (send_now) next_send_ = now + std::chrono::seconds(1);
  bool all_unreachable = !targets_.empty();
  for (auto& t : targets_) {
    if (!t.verdict) {
      ProbeSeen seen;
      seen.elapsed = std::chrono::duration_cast<std::chrono::milliseconds>(now - started_);
      seen.socket_error = socket_error(t.fd, send_now);
      seen.neighbour = neighbour_of(t.address);
      t.verdict = judge_host(seen);
    }
    if (t.verdict == model::HostVerdict::present) return t.verdict;
    all_unreachable = all_unreachable && t.verdict == model::HostVerdict::unreachable;
  }
  if (all_unreachable) return model::HostVerdict::unreachable;
  return std::nullopt;
}

std::optional<NeighbourSeen> neighbour_of(std::uint32_t address) {
  const int fd = socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd < 0) return std::nullopt;
  timeval timeout{0, 200000};  // the kernel answers a dump at once; this only bounds a surprise
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  struct {
    nlmsghdr head;
    ndmsg body;
  } request{};
  request.head.nlmsg_len = NLMSG_LENGTH(sizeof(ndmsg));
  request.head.nlmsg_type = RTM_GETNEIGH;
  request.head.nlmsg_flags = NLM_F_REQUEST | NLM_F_DUMP;
  request.body.ndm_family = AF_INET;
  std::optional<NeighbourSeen> found;
  if (send(fd, &request, request.head.nlmsg_len, 0) < 0) {
    close(fd);
    return std::nullopt;
  }
  alignas(nlmsghdr) char buf[16384];
  const long ticks_per_second = sysconf(_SC_CLK_TCK);
  for (bool done = false; !done;) {
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    auto len = static_cast<unsigned int>(n);
    for (auto* h = reinterpret_cast<nlmsghdr*>(buf); NLMSG_OK(h, len); h = NLMSG_NEXT(h, len)) {
      if (h->nlmsg_type == NLMSG_DONE || h->nlmsg_type == NLMSG_ERROR) {
        done = true;
        break;
      }
      if (h->nlmsg_type != RTM_NEWNEIGH) continue;
      const auto* nd = static_cast<const ndmsg*>(NLMSG_DATA(h));
      std::optional<std::uint32_t> dst;
      std::optional<nda_cacheinfo> cache;
      constexpr auto kHead = static_cast<unsigned int>(NLMSG_LENGTH(sizeof(ndmsg)));
      if (h->nlmsg_len < kHead) continue;
      unsigned int alen = h->nlmsg_len - kHead;
      for (auto* a = reinterpret_cast<const rtattr*>(reinterpret_cast<const char*>(nd) + NLMSG_ALIGN(sizeof(ndmsg)));
           RTA_OK(a, alen); a = RTA_NEXT(a, alen)) {
        if (a->rta_type == NDA_DST && RTA_PAYLOAD(a) == sizeof(std::uint32_t)) {
          std::uint32_t v;
          std::memcpy(&v, RTA_DATA(a), sizeof v);
          dst = v;
        } else if (a->rta_type == NDA_CACHEINFO && RTA_PAYLOAD(a) >= sizeof(nda_cacheinfo)) {
          nda_cacheinfo c;
          std::memcpy(&c, RTA_DATA(a), sizeof c);
          cache = c;
        }
      }
      if (dst != address || found) continue;
      NeighbourSeen seen;
      seen.state = nd->ndm_state;
      // In clock ticks (USER_HZ), as the kernel reports them.
      if (cache && ticks_per_second > 0)
        seen.confirmed_ago = std::chrono::milliseconds(static_cast<long long>(cache->ndm_confirmed) * 1000 /
                                                       ticks_per_second);
      else
        seen.confirmed_ago = std::chrono::milliseconds::max();
      found = seen;
    }
  }
  close(fd);
  return found;
}

}  // namespace rsd::net
