// Where one HTTP request ends in the bytes read so far, before anything parses it.
// The connection loop reads without blocking and hands a request to httplib only
// once it is all there, so a client that sends half a request (slowly, or never
// the rest) costs a buffer, never a thread. Pure: the unit tests and the fuzzer
// drive it directly.
#pragma once

#include <cstddef>
#include <string_view>

namespace rsd::api {

struct HeadLimits {
  std::size_t max_request_line = 8192;   // beyond: 414 (httplib's own limit too)
  std::size_t max_head = 32 * 1024;      // request line and headers; beyond: 431
  std::size_t max_body = 64 * 1024;      // the API takes no bodies; beyond: 413
};

enum class HeadVerdict {
  incomplete,      // wait for more bytes
  complete,        // head_length + body_length bytes make the request
  uri_too_long,    // 414
  head_too_large,  // 431
  body_too_large,  // 413
  bad_request,     // 400: a Content-Length that is no number
};

struct HeadScan {
  HeadVerdict verdict = HeadVerdict::incomplete;
  std::size_t head_length = 0;  // up to and including the blank line
  std::size_t body_length = 0;  // from Content-Length; 0 without it
  std::string_view target;      // the request line's second word (for routing the slow ones)
  std::size_t scanned = 0;      // incomplete: pass back as `resume` once more bytes came
};

// Looks at `buffer`, which starts at a request's first byte. Lines may end in
// CRLF or a bare LF (httplib accepts both). A chunked body is not measured here:
// nothing in the API takes one, and httplib answers it from what has arrived.
// `resume` is the previous incomplete scan's `scanned`: a client that drips its
// head a byte at a time then costs linear, not quadratic, scanning.
HeadScan scan_request_head(std::string_view buffer, const HeadLimits& limits, std::size_t resume = 0);

}  // namespace rsd::api
