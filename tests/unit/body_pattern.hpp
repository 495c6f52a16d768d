// A response body for the API's send-path tests: large enough for its memfd, with
// bytes that show any reordering or loss.
#pragma once

#include <cstddef>
#include <string>

inline std::string body_pattern(std::size_t n) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) s[i] = static_cast<char>('a' + (i * 7 + i / 251) % 26);
  return s;
}
