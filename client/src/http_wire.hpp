// The HTTP/1.1 the client speaks with the daemon: a GET request, and the reply's
// status line, headers and chunks read off the front of what came.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rsdiscovery::detail {

// The head of a reply: its status and the headers the client reads.
struct Head {
  int status = 0;
  std::string content_type, retry_after, etag, transfer_encoding, connection;
  std::optional<std::size_t> content_length;
};

// "GET path HTTP/1.1" with the client's headers and `extra`, up to the blank line.
std::string get_request(const std::string& path, const char* accept,
                        const std::vector<std::pair<std::string, std::string>>& extra);
bool iequals(std::string_view a, std::string_view b);  // ASCII, any case
// The status line and headers at the front of `buffer`, once all there; consumes them.
std::optional<Head> take_head(std::string& buffer, bool& malformed);
// Takes the next chunk of a chunked body off the front of `buffer`: its bytes in
// `out`; true when one was whole, with `last` set at the terminating chunk.
bool take_chunk(std::string& buffer, std::string& out, bool& last, bool& malformed);

}  // namespace rsdiscovery::detail
