// The API's send path: a response's head and body to the socket without copying
// the body (sendfile, or one splice through a pipe on a Unix socket), and the
// shared, sealed bodies (SharedBody) that many responses send at once.
#include "api/connection.hpp"

#include <algorithm>
#include <cerrno>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/sendfile.h>
#include <sys/socket.h>
#include <unistd.h>

namespace rsd::api {

namespace {

// A Unix socket wakes its reader for every send, and MSG_MORE does not hold it back as
// on TCP: a list's head and then its body were two wake-ups per response, and waking
// the client was the largest cost in the daemon's profile (sock_def_readable, under
// many connections). Through this thread's pipe the head (copied in) and the body
// (spliced from its memfd, not copied) reach the socket in one splice: one wake-up.
// The pipe is empty between calls: what the socket does not take is read back out
// and dropped, the caller still holding it (its `out` and its memfd).
class SplicePipe {
 public:
  // This thread's pipe (an event loop, or the blocking pool's thread serving a
  // parked request); nullptr when none can be made, and the caller sends as before.
  static SplicePipe* for_this_thread() {
    thread_local SplicePipe pipe;
    return pipe.read_ >= 0 ? &pipe : nullptr;
  }
  // A head no larger than this goes through the pipe (a list's is ~200 bytes).
  static constexpr std::size_t kMaxHead = 4096;

  // Sends `head` and then up to `body_length` bytes of `body` from `offset`; returns
  // how many bytes (head first) the socket took, or -1 with errno.
  ssize_t send(int socket, std::string_view head, const SharedBody& body, off_t offset, std::size_t body_length) {
    ssize_t in = ::write(write_, head.data(), head.size());
    if (in != static_cast<ssize_t>(head.size())) {  // an empty pipe takes a page: never
      drain(in > 0 ? static_cast<std::size_t>(in) : 0);
      errno = EIO;
      return -1;
    }
    // The whole body from its own pipe, by reference; else (the rest of a body the
    // socket took a part of) from the memfd.
    const bool whole = offset == 0 && body_length == body.bytes().size() && body.pipe() >= 0;
    const ssize_t spliced = whole ? ::tee(body.pipe(), write_, body_length, SPLICE_F_NONBLOCK)
                                  : ::splice(body.fd(), &offset, write_, nullptr, body_length, SPLICE_F_NONBLOCK);
    if (spliced > 0) in += spliced;
    ssize_t out;
    do out = ::splice(read_, nullptr, socket, nullptr, static_cast<std::size_t>(in), SPLICE_F_NONBLOCK);
    while (out < 0 && errno == EINTR);
    const int error = errno;
    drain(static_cast<std::size_t>(in - std::max<ssize_t>(out, 0)));
    errno = error;
    return out;
  }

  SplicePipe(const SplicePipe&) = delete;
  SplicePipe& operator=(const SplicePipe&) = delete;

 private:
  SplicePipe() {
    int fds[2];
    if (::pipe2(fds, O_NONBLOCK | O_CLOEXEC) != 0) return;
    read_ = fds[0];
    write_ = fds[1];
    // Room for a list of some 480 cameras at once; larger ones go in turns.
    ::fcntl(write_, F_SETPIPE_SZ, 256 * 1024);
  }
  ~SplicePipe() {
    if (read_ >= 0) ::close(read_);
    if (write_ >= 0) ::close(write_);
  }
  void drain(std::size_t left) {
    char scratch[4096];
    while (left > 0) {
      const ssize_t n = ::read(read_, scratch, std::min(left, sizeof scratch));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      left -= static_cast<std::size_t>(n);
    }
  }
  int read_ = -1, write_ = -1;
};

}  // namespace

bool send_pending(Connection& c) {
  Outbox& o = c.http.out();
  std::size_t turn = 0;
  while (o.pending() > 0) {
    if (turn >= kSendTurnBytes) return true;
    ssize_t n;
    SplicePipe* pipe = nullptr;
    if (!c.listener->http && o.file_left > 0 && o.out_pending() > 0 && o.out_pending() <= SplicePipe::kMaxHead)
      pipe = SplicePipe::for_this_thread();
    if (pipe) {
      n = pipe->send(c.fd, std::string_view(o.out).substr(o.out_pos), *o.file, static_cast<off_t>(o.file_offset),
                     o.file_left);
      if (n > 0) {
        auto sent = static_cast<std::size_t>(n);
        const auto from_out = std::min(sent, o.out_pending());
        o.out_pos += from_out;
        sent -= from_out;
        o.file_offset += sent;
        o.file_left -= sent;
      }
    } else if (o.out_pending() > 0) {
      const int more = o.file_left > 0 ? MSG_MORE : 0;  // the body follows at once
      n = ::send(c.fd, o.out.data() + o.out_pos, o.out_pending(), MSG_NOSIGNAL | MSG_DONTWAIT | more);
      if (n > 0) o.out_pos += static_cast<std::size_t>(n);
    } else {  // the socket is non-blocking: sendfile takes what fits and says so
      auto offset = static_cast<off_t>(o.file_offset);
      n = ::sendfile(c.fd, o.file->fd(), &offset, std::min(o.file_left, kSendTurnBytes - turn));
      if (n > 0) {
        o.file_offset += static_cast<std::size_t>(n);
        o.file_left -= static_cast<std::size_t>(n);
      }
    }
    if (n > 0) {
      turn += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    o.broken = true;
    return false;
  }
  o.out.clear();
  o.out_pos = 0;
  o.file.reset();
  return true;
}

SharedBody::SharedBody(std::string bytes) : bytes_(std::move(bytes)) {
  if (bytes_.size() < kDirectWrite) return;
  const int fd = memfd_create("rs-discoveryd-body", MFD_CLOEXEC | MFD_ALLOW_SEALING);
  if (fd < 0) return;
  std::size_t done = 0;
  while (done < bytes_.size()) {
    const ssize_t n = ::write(fd, bytes_.data() + done, bytes_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ::close(fd);
      return;
    }
    done += static_cast<std::size_t>(n);
  }
  // Sealed: what a client is sent can no longer change under it.
  fcntl(fd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_WRITE | F_SEAL_SEAL);
  fd_ = fd;
  fill_pipe();
}

// tee hands a pipe's pages to another pipe by reference, and the kernel does not let
// a later write into that pipe add to them: the body's pages are written once, here.
// A body beyond kMaxPipeBody (a list of some 2,000 cameras; a copy more of it held
// for each generation), or one the system will not give a pipe that large, goes from
// the memfd alone.
void SharedBody::fill_pipe() {
  constexpr std::size_t kMaxPipeBody = 1 << 20;  // Linux's default /proc/sys/fs/pipe-max-size
  int fds[2];
  if (bytes_.size() > kMaxPipeBody || ::pipe2(fds, O_NONBLOCK | O_CLOEXEC) != 0) return;
  const int capacity = ::fcntl(fds[1], F_SETPIPE_SZ, static_cast<int>(bytes_.size()));
  std::size_t done = 0;
  while (capacity >= static_cast<int>(bytes_.size()) && done < bytes_.size()) {
    const ssize_t n = ::write(fds[1], bytes_.data() + done, bytes_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  ::close(fds[1]);
  if (done == bytes_.size()) pipe_read_ = fds[0];
  else ::close(fds[0]);
}

SharedBody::~SharedBody() {
  if (fd_ >= 0) ::close(fd_);
  if (pipe_read_ >= 0) ::close(pipe_read_);
}

}  // namespace rsd::api
