#include "api/request_head.hpp"

#include <algorithm>
#include <cctype>

namespace rsd::api {

namespace {

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// The second space-separated word of the request line ("GET /v1/devices HTTP/1.1").
std::string_view target_of(std::string_view line) {
  const auto a = line.find(' ');
  if (a == std::string_view::npos) return {};
  const auto b = line.find(' ', a + 1);
  return line.substr(a + 1, b == std::string_view::npos ? std::string_view::npos : b - a - 1);
}

}  // namespace

HeadScan scan_request_head(std::string_view buffer, const HeadLimits& limits, std::size_t resume) {
  HeadScan out;
  out.scanned = buffer.size();
  // Blank lines before a request line are allowed (RFC 9112 2.2); httplib would
  // take the first one as a broken request line, so they count as the request's.
  const auto first_eol = buffer.find('\n');
  if (first_eol == std::string_view::npos) {
    if (buffer.size() > limits.max_request_line) out.verdict = HeadVerdict::uri_too_long;
    return out;
  }
  if (first_eol > limits.max_request_line) {
    out.verdict = HeadVerdict::uri_too_long;
    return out;
  }
  out.target = target_of(trim(buffer.substr(0, first_eol)));

  // The head ends at the first empty line: "\n\n" or "\n\r\n".
  std::size_t end = std::string_view::npos;
  // Up to `resume` no blank line was found; its last two bytes may begin one.
  const auto from = std::max(first_eol, resume > 2 ? resume - 2 : 0);
  for (auto pos = buffer.find('\n', from); pos != std::string_view::npos && pos < buffer.size(); pos = buffer.find('\n', pos + 1)) {
    const auto next = pos + 1;
    if (next < buffer.size() && buffer[next] == '\n') {
      end = next + 1;
      break;
    }
    if (next + 1 < buffer.size() && buffer[next] == '\r' && buffer[next + 1] == '\n') {
      end = next + 2;
      break;
    }
    if (next >= limits.max_head) break;
  }
  if (end == std::string_view::npos || end > limits.max_head) {
    // No end yet: too large already, or wait. (A CR just arrived may still be
    // followed by its LF, so the limit alone decides.)
    if (buffer.size() > limits.max_head || (end != std::string_view::npos && end > limits.max_head))
      out.verdict = HeadVerdict::head_too_large;
    return out;
  }
  out.head_length = end;

  // Content-Length, if any: the body's bytes belong to this request, and must
  // not be taken for the next one on a kept-alive connection.
  std::string_view rest = buffer.substr(first_eol + 1, end - first_eol - 1);
  while (!rest.empty()) {
    const auto eol = rest.find('\n');
    const auto line = trim(rest.substr(0, eol));
    rest = eol == std::string_view::npos ? std::string_view{} : rest.substr(eol + 1);
    const auto colon = line.find(':');
    if (colon == std::string_view::npos || !iequals(trim(line.substr(0, colon)), "content-length")) continue;
    const auto value = trim(line.substr(colon + 1));
    if (value.empty() || value.size() > 18 ||
        !std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      out.verdict = HeadVerdict::bad_request;
      return out;
    }
    std::size_t n = 0;
    for (char c : value) n = n * 10 + static_cast<std::size_t>(c - '0');
    if (n > limits.max_body) {
      out.verdict = HeadVerdict::body_too_large;
      return out;
    }
    out.body_length = n;
  }
  out.verdict = HeadVerdict::complete;
  return out;
}

}  // namespace rsd::api
