// rs-discover and the daemon: the client the options make (the endpoint, with a
// fallback to HTTP on loopback; the wait for a complete table), the device filter
// from the options, and each library error as a message and an exit status.
#include "common.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>

namespace rsdiscover {

using rsdiscovery::ErrorCode;

rsdiscovery::ClientOptions client_options(const ParsedArgs& args) {
  rsdiscovery::ClientOptions options;
  if (args.has("no-wait-complete") && args.has("complete-timeout"))
    throw UsageError("--no-wait-complete and --complete-timeout exclude each other");
  if (args.has("no-wait-complete")) {
    options.complete_timeout(std::chrono::milliseconds::zero());
  } else if (args.has("complete-timeout")) {
    options.complete_timeout(
        std::chrono::milliseconds(static_cast<long long>(args.get_seconds("complete-timeout", 0) * 1000)));
  }
  // A busy daemon is waited for as it asks; the user sees why the command pauses.
  options.on_busy([](const std::string& why) { std::fprintf(stderr, "rs-discover: %s\n", why.c_str()); });
  return options;
}

namespace {
// 0 when something accepts a connection on the Unix socket at `path`, else errno.
int connect_error(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) return ENAMETOOLONG;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return errno;
  const int rc = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  const int err = rc == 0 ? 0 : errno;
  ::close(fd);
  return err;
}
}  // namespace

rsdiscovery::Client make_client(const ParsedArgs& args) {
  const auto options = client_options(args);
  const char* env = std::getenv("RS_DISCOVERY_ENDPOINT");
  if (args.has("endpoint") || (env && *env)) return rsdiscovery::Client(args.get("endpoint"), options);
  // No endpoint given: the daemon's default socket, or, when there is no socket there
  // or nothing listens on it, the daemon's default HTTP address on loopback (a daemon
  // run as another user, in a container, or with a socket made elsewhere). Only a
  // missing or refused socket: a permission error says which group to join.
  auto socket = rsdiscovery::Endpoint::default_socket();
  const int err = connect_error(socket.path);
  if (err != ENOENT && err != ENOTDIR && err != ECONNREFUSED) return rsdiscovery::Client(socket, options);
  const auto http = rsdiscovery::Endpoint::parse("127.0.0.1");  // the daemon's default port
  const std::string why = err == ECONNREFUSED ? "nothing listens on " + socket.path : "no socket at " + socket.path;
  try {
    auto quick = options;
    quick.connect_timeout(std::chrono::milliseconds(500));
    rsdiscovery::Client client(http, quick);
    client.health();  // it is rs-discoveryd that answers there
    std::fprintf(stderr, "rs-discover: %s; using %s\n", why.c_str(), http.to_string().c_str());
    return rsdiscovery::Client(http, options);
  } catch (const rsdiscovery::Error& e) {
    const std::string there = e.code() == rsdiscovery::ErrorCode::not_running
                                  ? "nothing answers at " + http.to_string()
                                  : http.to_string() + " is not rs-discoveryd (" + e.what() + ")";
    throw rsdiscovery::Error(rsdiscovery::ErrorCode::not_running,
                             "cannot reach rs-discoveryd: " + why + ", and " + there +
                                 " (is it running? Give its endpoint with --endpoint or RS_DISCOVERY_ENDPOINT)");
  }
}

rsdiscovery::DeviceFilter filter_from(const ParsedArgs& args) {
  rsdiscovery::DeviceFilter f;
  for (int d : args.get_ints("domain", 0, 232)) f.domain(d);
  f.serial(args.get("serial")).name(args.get("name")).address(args.get("address"));
  f.product_line(args.get("product-line"));
  const std::string source = args.get("source");
  if (!source.empty() && source != "dds" && source != "usb" && source != "remote-usb")
    throw UsageError("--source wants dds, usb or remote-usb, not '" + source + "'");
  f.source(source);
  // --host: another host's cameras by its name; the daemon matches it (?host=) and
  // selects remote-usb with it, so another source could only answer nothing.
  if (args.has("host")) {
    if (args.get("host").empty()) throw UsageError("--host wants a host name");
    if (!source.empty() && source != "remote-usb")
      throw UsageError("--host selects another host's cameras (remote-usb), not --source " + source);
    f.host(args.get("host"));
  }
  if (args.has("in-use") && args.has("free")) throw UsageError("--in-use and --free exclude each other");
  if (args.has("in-use")) f.in_use(true);
  if (args.has("free")) f.in_use(false);
  return f;
}

void exit_now(int status) {
  std::fflush(nullptr);
  std::_Exit(status);
}

void warn_incomplete() {
  // stderr, and still exit 0: the answer is right about every camera it lists, and
  // scripts reading stdout keep working; a human learns why one may be missing.
  std::fputs("rs-discover: warning: rs-discoveryd has not finished its first discovery (it started moments "
             "ago); cameras may be missing from this answer\n",
             stderr);
}

void report_no_device(const std::string& key) {
  std::fprintf(stderr,
               "rs-discover: no device '%s' (ids are listed by 'rs-discover list -q'; 'rs-discover doctor' "
               "says why a camera may be missing)\n",
               key.c_str());
}

int report(const rsdiscovery::Error& e) {
  std::fprintf(stderr, "rs-discover: %s\n", e.what());
  switch (e.code()) {
    case ErrorCode::not_found:
    case ErrorCode::timeout:
      return kNotFound;
    case ErrorCode::bad_endpoint:
      return kUsage;
    case ErrorCode::not_running:
    case ErrorCode::permission_denied:
    case ErrorCode::cancelled:
      return kUnreachable;
    case ErrorCode::http_error:
      // The daemon understood and could not: a camera it cannot describe (409:
      // recovery firmware, a serial of several) or that did not answer in time (504,
      // 503): not found or timed out, as the exit status has it.
      if (e.http_status() == 409 || e.http_status() == 503 || e.http_status() == 504) return kNotFound;
      return kBadReply;
    case ErrorCode::malformed_reply:
    case ErrorCode::version_mismatch:
      return kBadReply;
  }
  return kBadReply;
}

}  // namespace rsdiscover
