// rsd-bench-client-list: in-process list of the daemon's devices through the client
// library, timed call by call, for bench/run: rsdiscovery::Client::list (a request to
// the daemon each call) and a kept rsdiscovery::DeviceView's devices() (no request).
//
//   rsd-bench-client-list ENDPOINT [ITERATIONS] [WARMUP]
//
// One Client, kept; WARMUP untimed calls first; then ITERATIONS timed calls. A kept
// client's list of an unchanged table is one request answered 304 and a copy of the
// list it holds, so the same run also times both alone, as its anchors: copying the
// list (what any call returning it by value pays) and the same request answered 304 on
// a plain socket of this process (what asking the daemon at all costs). ENDPOINT is
// unix:PATH or http://127.0.0.1:PORT. A DeviceView's list is a copy of the view it
// keeps, so copying the list is its anchor too. Prints one JSON object: devices,
// iterations, microseconds (min, p10, median, p90, p99, max), the view's median and p99,
// and the anchors' medians.
#include <rsdiscovery/rsdiscovery.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double us_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? -1.0 : v[v.size() / 2];
}

int connect_to(const std::string& endpoint) {
  if (endpoint.rfind("unix:", 0) == 0) {
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof a.sun_path, "%s", endpoint.c_str() + 5);
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0)
      throw std::runtime_error("cannot connect to " + endpoint);
    return fd;
  }
  const auto colon = endpoint.rfind(':');
  if (endpoint.rfind("http://", 0) != 0 || colon == std::string::npos || colon < 7)
    throw std::runtime_error("endpoint " + endpoint + ": unix:PATH or http://ADDRESS:PORT");
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(std::atoi(endpoint.c_str() + colon + 1)));
  if (inet_pton(AF_INET, endpoint.substr(7, colon - 7).c_str(), &a.sin_addr) != 1)
    throw std::runtime_error("endpoint " + endpoint + ": a numeric IPv4 address");
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0)
    throw std::runtime_error("cannot connect to " + endpoint);
  return fd;
}

// Sends `request` and reads one response head with no body (a 304); returns the head.
std::string round_trip(int fd, const std::string& request) {
  if (::send(fd, request.data(), request.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(request.size()))
    throw std::runtime_error("send failed");
  std::string head;
  char buf[4096];
  while (head.find("\r\n\r\n") == std::string::npos) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) throw std::runtime_error("the daemon closed the connection");
    head.append(buf, static_cast<std::size_t>(n));
  }
  return head;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s ENDPOINT [ITERATIONS] [WARMUP]\n", argv[0]);
    return 2;
  }
  const std::string endpoint = argv[1];
  const int iterations = argc > 2 ? std::atoi(argv[2]) : 2000;
  const int warmup = argc > 3 ? std::atoi(argv[3]) : 50;
  try {
    rsdiscovery::Client client{endpoint};
    std::size_t devices = 0;
    for (int i = 0; i < warmup; i++) devices = client.list().devices.size();
    std::vector<double> us;
    us.reserve(static_cast<std::size_t>(iterations));
    for (int i = 0; i < iterations; i++) {
      const auto t0 = Clock::now();
      const auto list = client.list();
      us.push_back(us_since(t0));
      devices = list.devices.size();
    }

    const auto kept = client.list();
    std::vector<double> copy_us;
    for (int i = 0; i < iterations; i++) {
      const auto t0 = Clock::now();
      const auto copy = kept;
      copy_us.push_back(us_since(t0));
      devices = copy.devices.size();
    }

    // The library's own request for the kept list, its ETag from the daemon's answer.
    const int fd = connect_to(endpoint);
    const std::string plain = "GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nContent-Length: 0\r\n\r\n";
    if (::send(fd, plain.data(), plain.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(plain.size()))
      throw std::runtime_error("send failed");
    std::string reply;
    char buf[65536];
    std::string etag;
    for (;;) {  // the whole 200: its head says the ETag and how long the body is
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) throw std::runtime_error("the daemon closed the connection");
      reply.append(buf, static_cast<std::size_t>(n));
      const auto end = reply.find("\r\n\r\n");
      if (end == std::string::npos) continue;
      const auto e = reply.find("ETag: ");
      const auto l = reply.find("Content-Length: ");
      if (e == std::string::npos || l == std::string::npos) throw std::runtime_error("no ETag or length");
      etag = reply.substr(e + 6, reply.find("\r\n", e) - e - 6);
      if (reply.size() >= end + 4 + std::strtoull(reply.c_str() + l + 16, nullptr, 10)) break;
    }
    const std::string conditional = "GET /v1/devices HTTP/1.1\r\nHost: localhost\r\nIf-None-Match: " + etag + "\r\n\r\n";
    std::vector<double> request_us;
    for (int i = 0; i < iterations + warmup; i++) {
      const auto t0 = Clock::now();
      const auto head = round_trip(fd, conditional);
      if (i >= warmup) request_us.push_back(us_since(t0));
      if (head.rfind("HTTP/1.1 304", 0) != 0) throw std::runtime_error("not a 304: " + head.substr(0, 40));
    }
    ::close(fd);

    const auto view = client.view();
    // Listed before view() returns; the check only guards what is timed below.
    if (view.devices().size() != devices) throw std::runtime_error("the view holds another number of devices");
    std::vector<double> view_us;
    for (int i = 0; i < iterations + warmup; i++) {
      const auto t0 = Clock::now();
      const auto listed = view.devices();
      if (i >= warmup) view_us.push_back(us_since(t0));
      devices = listed.size();
    }
    std::sort(view_us.begin(), view_us.end());

    std::sort(us.begin(), us.end());
    auto at = [&](double p) { return us.empty() ? -1.0 : us[static_cast<std::size_t>(p * double(us.size() - 1) + 0.5)]; };
    std::printf(
        "{\"devices\": %zu, \"iterations\": %d, \"min_us\": %.2f, \"p10_us\": %.2f, \"median_us\": %.2f, "
        "\"p90_us\": %.2f, \"p99_us\": %.2f, \"max_us\": %.2f, \"copy_median_us\": %.2f, "
        "\"request_304_median_us\": %.2f, \"view_median_us\": %.2f, \"view_p99_us\": %.2f}\n",
        devices, iterations, at(0), at(0.10), at(0.50), at(0.90), at(0.99), at(1.0), median(copy_us),
        median(request_us), view_us[view_us.size() / 2], view_us[view_us.size() * 99 / 100]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rsd-bench-client-list: %s\n", e.what());
    return 1;
  }
  return 0;
}
