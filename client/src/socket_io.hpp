// The transport's sockets: connecting to the daemon (a Unix socket or TCP) within a
// timeout, and reading and writing until a deadline, stopped by a cancel flag.
#pragma once

#include "rsdiscovery/rsdiscovery.hpp"

#include <atomic>
#include <chrono>
#include <string>
#include <string_view>

namespace rsdiscovery::detail {

// Why a read or write ended early.
enum class IoEnd { ok, closed, timeout, cancelled, failed };

using Deadline = std::chrono::steady_clock::time_point;

// A connected non-blocking socket, or -1 (diagnose_connect() then says why).
int open_socket(const Endpoint& endpoint, std::chrono::milliseconds timeout);
IoEnd write_all(int fd, std::string_view data, Deadline deadline, const std::atomic<bool>& cancelled);
// Appends what the socket has to `buffer` (as much as its spare capacity holds),
// waiting until `deadline` for something.
IoEnd read_some(int fd, std::string& buffer, Deadline deadline, const std::atomic<bool>& cancelled);

}  // namespace rsdiscovery::detail
