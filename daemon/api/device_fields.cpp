// GET /v1/devices?fields=: the names a client asks for, and each device's document
// cut to them from the table's text (format.hpp says what the parameter means).
#include "api/format.hpp"

#include <algorithm>

namespace rsd::api {

std::optional<std::string> parse_device_fields(const QueryParams& params, DeviceFields& out) {
  constexpr std::size_t kMaxFields = 32, kMaxPart = 64;
  const auto [begin, end] = params.equal_range("fields");
  for (auto it = begin; it != end; ++it) {
    const std::string& value = it->second;
    if (value.empty()) return std::string("empty fields: name the device keys, separated by commas");
    std::size_t start = 0;
    for (;;) {
      const std::size_t comma = std::min(value.find(',', start), value.size());
      const std::string_view name(value.data() + start, comma - start);
      std::vector<std::string> path;
      std::size_t part_start = 0;
      for (;;) {
        const std::size_t dot = std::min(name.find('.', part_start), name.size());
        const std::string_view part = name.substr(part_start, dot - part_start);
        const bool ok = !part.empty() && part.size() <= kMaxPart && std::all_of(part.begin(), part.end(), [](char c) {
          return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
        });
        if (!ok) return "bad fields '" + value + "': expected names such as name,serial,server.addresses";
        path.emplace_back(part);
        if (dot == name.size()) break;
        part_start = dot + 1;
      }
      if (std::find(out.paths.begin(), out.paths.end(), path) == out.paths.end()) out.paths.push_back(std::move(path));
      if (out.paths.size() > kMaxFields) return "too many fields (at most " + std::to_string(kMaxFields) + ")";
      if (comma == value.size()) break;
      start = comma + 1;
    }
  }
  return std::nullopt;
}

namespace {

// Where the JSON value at text[i] ends (one past it), in text as dump() writes it:
// strings with their escapes skipped, containers by depth; a scalar ends at the
// ',' or closing bracket after it. text.size() when it runs out.
std::size_t value_end(std::string_view text, std::size_t i) {
  int depth = 0;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"') {
      for (++i; i < text.size() && text[i] != '"'; ++i)
        if (text[i] == '\\') ++i;
      if (depth == 0) return std::min(i + 1, text.size());
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      if (--depth <= 0) return depth == 0 ? i + 1 : i;
    } else if (c == ',' && depth == 0) {
      return i;
    }
  }
  return text.size();
}

// Appends the members of the object `obj` that `paths` name at `level` (the whole
// member, or for a longer path the same cut of its object), in the object's order;
// with_id: "id" too. Nothing, not even "{}", when none is there: returns false.
bool project_object(std::string_view obj, const std::vector<const std::vector<std::string>*>& paths,
                    std::size_t level, bool with_id, std::string& out) {
  const std::size_t start = out.size();
  out += '{';
  bool any = false;
  for (std::size_t i = 1; i < obj.size() && obj[i] == '"';) {
    const std::size_t key_end = value_end(obj, i);
    if (key_end < i + 2 || key_end >= obj.size() || obj[key_end] != ':') break;
    const std::string_view key = obj.substr(i + 1, key_end - i - 2);
    const std::size_t v = key_end + 1, v_end = value_end(obj, v);
    bool whole = with_id && key == "id";
    std::vector<const std::vector<std::string>*> inner;
    for (const auto* p : paths)
      if ((*p)[level] == key) (p->size() == level + 1 ? whole = true : (inner.push_back(p), false));
    if (whole || (!inner.empty() && v < obj.size() && obj[v] == '{')) {
      const std::size_t mark = out.size();
      if (any) out += ',';
      out.append(obj.substr(i, v - i));  // "key":
      if (whole)
        out.append(obj.substr(v, v_end - v));
      else if (!project_object(obj.substr(v, v_end - v), inner, level + 1, false, out))
        out.resize(mark);
      any = any || out.size() != mark;
    }
    i = v_end + 1;  // past the ','
  }
  if (!any && !with_id) {
    out.resize(start);
    return false;
  }
  out += '}';
  return true;
}

}  // namespace

std::string project_device(std::string_view text, const DeviceFields& fields) {
  // Cut from the entry's own text, not made again from its model (to_json and dump
  // of each device would cost more than cutting, once per generation and query).
  std::vector<const std::vector<std::string>*> paths;
  for (const auto& p : fields.paths) paths.push_back(&p);
  std::string out;
  out.reserve(text.size());
  project_object(text, paths, 0, true, out);
  return out;
}

}  // namespace rsd::api
