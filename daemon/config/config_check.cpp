#include "config/config_check.hpp"

#include <fstream>
#include <regex>
#include <sstream>

namespace rsd {

std::pair<int, int> top_level_key_position(const std::string& text, const std::string& key) {
  int depth = 0, line = 1, column = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    ++column;
    if (c == '\n') {
      ++line;
      column = 0;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      --depth;
    } else if (c == '"') {
      const int at_line = line, at_column = column;
      std::string content;
      for (++i; i < text.size() && text[i] != '"'; ++i) {
        if (text[i] == '\\' && i + 1 < text.size()) {
          content += text[i++];
          ++column;
        }
        content += text[i];
        ++column;
      }
      ++column;  // the closing quote
      if (depth != 1 || content != key) continue;
      auto after = text.find_first_not_of(" \t\r\n", i + 1);
      if (after != std::string::npos && text[after] == ':') return {at_line, at_column};
    }
  }
  return {0, 0};
}

std::string locate_config_error(const std::string& message) {
  std::smatch m;
  // nlohmann's syntax errors say where the parser stopped.
  static const std::regex syntax(R"re(^(.+?): not valid JSON: .*? at line (\d+), column (\d+): (.*)$)re");
  if (std::regex_match(message, m, syntax))
    return m[1].str() + ":" + m[2].str() + ":" + m[3].str() + ": not valid JSON: " + m[4].str();
  // A bad value: 'PATH: "key" must be ...' (apply_config_json's form).
  static const std::regex value(R"re(^(.+?): ("([^"]*)".*)$)re");
  if (!std::regex_match(message, m, value)) return message;
  std::ifstream in(m[1].str(), std::ios::binary);
  if (!in) return message;
  std::ostringstream text;
  text << in.rdbuf();
  const auto [line, column] = top_level_key_position(text.str(), m[3].str());
  if (line == 0) return message;
  return m[1].str() + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " + m[2].str();
}

}  // namespace rsd
