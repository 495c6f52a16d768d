// An eventfd that another thread writes to wake the main loop, which polls it
// beside the signalfd (as Avahi's simple-watch wakes its loop through a pipe).
#pragma once

namespace rsd::service {

class WakeFd {
 public:
  WakeFd();   // logs when no eventfd can be made: fd() is -1 then, wake() does nothing
  ~WakeFd();
  WakeFd(const WakeFd&) = delete;
  WakeFd& operator=(const WakeFd&) = delete;

  int fd() const { return fd_; }
  void wake() const;  // any thread; wakes pending at once are one
  bool take();        // main thread: whether it was woken since the last take()

 private:
  int fd_ = -1;
};

}  // namespace rsd::service
