// An enum of the API read back from its name: the one lookup behind parse_domain_state,
// parse_vendor and parse_participant_state. Each enum keeps its own to_string switch,
// so the compiler still checks every enumerator has a name.
#pragma once

#include <initializer_list>
#include <optional>
#include <string_view>

namespace rsd::model {

// The enumerator of `all` whose to_string() is `name`, exactly; nothing otherwise.
template <class Enum>
constexpr std::optional<Enum> parse_name(std::string_view name, std::initializer_list<Enum> all) {
  for (Enum e : all)
    if (to_string(e) == name) return e;
  return std::nullopt;
}

}  // namespace rsd::model
