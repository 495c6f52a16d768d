// The expected cameras of the running configuration, readable from any thread: the
// service sets them at start and on every reload (main thread), the API's threads
// read them through StatusView::expected().
#pragma once

#include "rsd_model/expected.hpp"

#include <mutex>
#include <vector>

namespace rsd::service {

class ExpectedSet {
 public:
  void set(std::vector<model::ExpectedCamera> cameras) {
    std::lock_guard lock(mutex_);
    cameras_ = std::move(cameras);
  }
  std::vector<model::ExpectedCamera> get() const {
    std::lock_guard lock(mutex_);
    return cameras_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<model::ExpectedCamera> cameras_;
};

}  // namespace rsd::service
