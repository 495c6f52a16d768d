// Fuzz target for the API's value parsers, straight (cheaper than through a request,
// so more of them): a domain, a generation (since, Last-Event-ID), an If-None-Match
// against an ETag, a Host header, and a query of filters and fields. Lines of the
// input are the values. Every parser answers, and what it accepts is in range.
#include "api/format.hpp"
#include "api/host_check.hpp"

#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  std::vector<std::string_view> v;
  for (std::size_t start = 0; v.size() < 6;) {
    const auto nl = in.find('\n', start);
    v.push_back(in.substr(start, nl == std::string_view::npos ? std::string_view::npos : nl - start));
    if (nl == std::string_view::npos) break;
    start = nl + 1;
  }
  v.resize(6);
  if (const auto d = rsd::api::parse_domain(v[0]); d && (*d < 0 || *d > 232)) std::abort();
  (void)rsd::api::parse_generation(v[1]);
  if (!rsd::api::etag_matches("*", v[3])) std::abort();  // "*" matches any tag
  (void)rsd::api::etag_matches(v[2], v[3]);
  const rsd::api::HostCheck check({"127.0.0.1", std::string(v[3])}, (size & 1) != 0, {std::string(v[5])});
  (void)check.allows(v[4]);
  rsd::api::QueryParams params;
  for (std::size_t start = 0; start <= v[5].size();) {
    const auto amp = v[5].find('&', start);
    const auto part = v[5].substr(start, amp == std::string_view::npos ? std::string_view::npos : amp - start);
    const auto eq = part.find('=');
    params.emplace(std::string(part.substr(0, eq)), eq == std::string_view::npos ? "" : std::string(part.substr(eq + 1)));
    if (amp == std::string_view::npos) break;
    start = amp + 1;
  }
  rsd::api::DeviceFilter filter;
  if (!rsd::api::parse_device_filter(params, filter, {"since"})) {
    for (int d : filter.domains)
      if (d < 0 || d > 232) std::abort();
    (void)filter.matches(rsd::model::device_from_json(nlohmann::json::parse(v[4], nullptr, false)));
  }
  rsd::api::DeviceFields fields;  // ?fields=: a bounded list, and a projection is an object
  if (!rsd::api::parse_device_fields(params, fields)) {
    if (fields.paths.size() > 32) std::abort();
    for (const auto& path : fields.paths)
      for (const auto& part : path)
        if (part.empty() || part.size() > 64) std::abort();
    const auto doc = nlohmann::json::parse(v[4], nullptr, false);
    // Cut from the text, it is what the document cut and written again would be.
    if (doc.is_object()) {
      const auto cut = nlohmann::json::parse(rsd::api::project_device(rsd::api::dump(doc), fields), nullptr, false);
      if (!cut.is_object() || !cut.contains("id") != !doc.contains("id")) std::abort();
      for (const auto& [key, value] : cut.items())
        if (!doc.contains(key) || (value.is_object() ? !doc[key].is_object() : doc[key] != value)) std::abort();
    }
  }
  (void)rsd::api::check_params("/v1/domains", params, {});
  (void)rsd::api::sse_message(v[0], rsd::api::parse_generation(v[1]), v[2]);
  return 0;
}
