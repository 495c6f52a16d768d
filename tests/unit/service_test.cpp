// The pure parts of daemon/service: STATUS= text and what a passed socket is for.
#include "service/listen_sockets.hpp"
#include "service/service.hpp"

#include <gtest/gtest.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <string>

using rsd::service::classify_socket;
using rsd::service::SocketRole;
using rsd::service::status_text;

TEST(StatusText, CountsDomainsUsbAndNote) {
  EXPECT_EQ(status_text("", 3, {0, 5}, false, ""), "3 devices on DDS domains 0,5");
  EXPECT_EQ(status_text("", 1, {0}, true, ""), "1 device on DDS domain 0 and USB");
  EXPECT_EQ(status_text("starting", 0, {7}, false, ""), "starting: 0 devices on DDS domain 7");
  EXPECT_EQ(status_text("", 2, {}, true, "reload failed: x"), "2 devices on USB; reload failed: x");
}

namespace {

struct Fd {
  int fd;
  explicit Fd(int f) : fd(f) {}
  ~Fd() {
    if (fd >= 0) close(fd);
  }
};

int unix_listener(const std::string& path) {
  int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
  unlink(path.c_str());
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || listen(fd, 4) != 0) ADD_FAILURE() << "unix bind";
  return fd;
}

int tcp_socket(bool listening) {
  int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) ADD_FAILURE() << "tcp bind";
  if (listening && listen(fd, 4) != 0) ADD_FAILURE() << "tcp listen";
  return fd;
}

}  // namespace

TEST(ClassifySocket, ByNameOrElseByFamily) {
  const std::string path = "/tmp/rsd-classify-" + std::to_string(getpid()) + ".sock";
  Fd u(unix_listener(path)), t(tcp_socket(true));
  std::string why;
  EXPECT_EQ(classify_socket(u.fd, "unix", why), SocketRole::unix_api);
  EXPECT_EQ(classify_socket(t.fd, "http", why), SocketRole::http);
  // systemd-socket-activate without --fdname, or a unit's default name
  EXPECT_EQ(classify_socket(u.fd, "unknown", why), SocketRole::unix_api);
  EXPECT_EQ(classify_socket(t.fd, "rs-discoveryd.socket", why), SocketRole::http);
  unlink(path.c_str());
}

TEST(ClassifySocket, WrongKindIsUnusableWithAReason) {
  const std::string path = "/tmp/rsd-classify2-" + std::to_string(getpid()) + ".sock";
  Fd u(unix_listener(path)), t(tcp_socket(true)), idle(tcp_socket(false));
  Fd dgram(socket(AF_INET, SOCK_DGRAM, 0));
  std::string why;
  EXPECT_EQ(classify_socket(u.fd, "http", why), SocketRole::unusable);
  EXPECT_NE(why.find("named for HTTP"), std::string::npos) << why;
  EXPECT_EQ(classify_socket(t.fd, "unix", why), SocketRole::unusable);
  EXPECT_EQ(classify_socket(idle.fd, "unknown", why), SocketRole::unusable);  // not listening
  EXPECT_EQ(classify_socket(dgram.fd, "unknown", why), SocketRole::unusable);
  EXPECT_NE(why.find("not a listening"), std::string::npos) << why;
  unlink(path.c_str());
}

TEST(StatusText, ExpectedCameras) {
  rsd::model::ExpectedReport report;
  EXPECT_EQ(rsd::service::expected_text(report), "");
  report.present.push_back({{"front", "1", ""}, "dds-0-x", {}, {}});
  report.missing.push_back({{"wrist", "", "realsense/D555_2"}, {}, {}, {}});
  report.missing.push_back({{"", "3", ""}, {}, {}, {}});
  EXPECT_EQ(rsd::service::expected_text(report),
            "1 of 3 expected cameras (missing: wrist (realsense/D555_2), 3)");
}
