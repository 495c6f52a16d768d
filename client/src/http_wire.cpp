// The HTTP/1.1 the client speaks with the daemon, for exactly what the daemon sends
// (replies with Content-Length, chunked, or until close): the request, the reply's
// head and chunks.
#include "http_wire.hpp"

#include "rsdiscovery/rsdiscovery.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>

namespace rsdiscovery::detail {
namespace {

std::string_view trim(std::string_view v) {
  while (!v.empty() && (v.front() == ' ' || v.front() == '\t')) v.remove_prefix(1);
  while (!v.empty() && (v.back() == ' ' || v.back() == '\t' || v.back() == '\r')) v.remove_suffix(1);
  return v;
}

}  // namespace

std::string get_request(const std::string& path, const char* accept,
                        const std::vector<std::pair<std::string, std::string>>& extra) {
  std::string out = "GET " + path + " HTTP/1.1\r\nHost: localhost\r\nAccept: " + accept +
                    "\r\nAccept-Encoding: identity\r\nUser-Agent: rsdiscovery/" + version() + "\r\n";
  for (const auto& [k, v] : extra) out += k + ": " + v + "\r\n";
  return out + "\r\n";
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

std::optional<Head> take_head(std::string& buffer, bool& malformed) {
  const auto end = buffer.find("\r\n\r\n");
  if (end == std::string::npos) {
    malformed = buffer.size() > 65536;
    return std::nullopt;
  }
  Head head;
  std::string_view text(buffer.data(), end);
  const auto eol = text.find("\r\n");
  const auto status_line = text.substr(0, eol);
  if (status_line.substr(0, 5) != "HTTP/" || status_line.size() < 12) {
    malformed = true;
    return std::nullopt;
  }
  head.status = std::atoi(std::string(status_line.substr(9, 3)).c_str());
  text = eol == std::string_view::npos ? std::string_view{} : text.substr(eol + 2);
  while (!text.empty()) {
    const auto next = text.find("\r\n");
    const auto line = text.substr(0, next);
    text = next == std::string_view::npos ? std::string_view{} : text.substr(next + 2);
    const auto colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    const auto name = trim(line.substr(0, colon));
    const auto value = std::string(trim(line.substr(colon + 1)));
    if (iequals(name, "Content-Length")) {
      char* stop = nullptr;
      const auto n = std::strtoull(value.c_str(), &stop, 10);
      if (value.empty() || *stop) {
        malformed = true;
        return std::nullopt;
      }
      head.content_length = static_cast<std::size_t>(n);
    } else if (iequals(name, "Content-Type")) {
      head.content_type = value;
    } else if (iequals(name, "Retry-After")) {
      head.retry_after = value;
    } else if (iequals(name, "ETag")) {
      head.etag = value;
    } else if (iequals(name, "Transfer-Encoding")) {
      head.transfer_encoding = value;
    } else if (iequals(name, "Connection")) {
      head.connection = value;
    }
  }
  buffer.erase(0, end + 4);
  return head;
}

bool take_chunk(std::string& buffer, std::string& out, bool& last, bool& malformed) {
  const auto eol = buffer.find("\r\n");
  if (eol == std::string::npos) {
    malformed = buffer.size() > 64;
    return false;
  }
  char* stop = nullptr;
  const auto size = std::strtoull(buffer.c_str(), &stop, 16);
  if (stop == buffer.c_str()) {
    malformed = true;
    return false;
  }
  if (size == 0) {
    // The last chunk; trailers are not used by the daemon: up to the blank line.
    const auto end = buffer.find("\r\n\r\n", eol);
    if (end == std::string::npos && buffer.compare(eol, 4, "\r\n\r\n") != 0) return false;
    buffer.erase(0, (end == std::string::npos ? eol : end) + 4);
    last = true;
    return true;
  }
  if (buffer.size() < eol + 2 + size + 2) return false;
  out.append(buffer, eol + 2, size);
  buffer.erase(0, eol + 2 + size + 2);
  return true;
}

}  // namespace rsdiscovery::detail
