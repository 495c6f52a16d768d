#include "rsd_model/description.hpp"

namespace rsd::model {

namespace {

// Every key of the document: nothing else spells them.
namespace key {
constexpr const char* streams = "streams";
constexpr const char* device_options = "device-options";
constexpr const char* extrinsics = "extrinsics";
constexpr const char* presets = "presets";
constexpr const char* name = "name";
constexpr const char* type = "type";
constexpr const char* sensor_name = "sensor-name";
constexpr const char* profiles = "profiles";
constexpr const char* default_profile = "default-profile";
constexpr const char* metadata_enabled = "metadata-enabled";
constexpr const char* options = "options";
constexpr const char* intrinsics = "intrinsics";
constexpr const char* embedded_filters = "embedded-filters";
constexpr const char* fps = "fps";
constexpr const char* format = "format";
constexpr const char* width = "width";
constexpr const char* height = "height";
constexpr const char* value = "value";
constexpr const char* min = "min";
constexpr const char* max = "max";
constexpr const char* step = "step";
constexpr const char* default_value = "default";
constexpr const char* description = "description";
constexpr const char* json = "json";
constexpr const char* from = "from";
constexpr const char* to = "to";
constexpr const char* rotation = "rotation";
constexpr const char* translation = "translation";
}  // namespace key

[[noreturn]] void bad(const std::string& what) { throw MalformedDocument("a description " + what); }

const nlohmann::json& member(const nlohmann::json& doc, const char* name) {
  if (!doc.is_object()) bad("has something that is not an object where one belongs");
  const auto it = doc.find(name);
  if (it == doc.end()) bad(std::string("lacks \"") + name + "\"");
  return *it;
}

std::string text(const nlohmann::json& doc, const char* name) {
  const auto& v = member(doc, name);
  if (!v.is_string()) bad(std::string("has a \"") + name + "\" that is not a string");
  return v.get<std::string>();
}

const nlohmann::json& array(const nlohmann::json& doc, const char* name) {
  const auto& v = member(doc, name);
  if (!v.is_array()) bad(std::string("has a \"") + name + "\" that is not a list");
  return v;
}

int whole(const nlohmann::json& v, const char* name) {
  if (!v.is_number_integer()) bad(std::string("has a \"") + name + "\" that is not a whole number");
  return v.get<int>();
}

nlohmann::json optional_member(const nlohmann::json& doc, const char* name) {
  const auto it = doc.find(name);
  return it == doc.end() ? nlohmann::json() : *it;
}

Profile profile_from(const nlohmann::json& p) {
  Profile out;
  out.fps = whole(member(p, key::fps), key::fps);
  if (p.contains(key::format)) out.format = text(p, key::format);
  if (p.contains(key::width)) out.width = whole(p[key::width], key::width);
  if (p.contains(key::height)) out.height = whole(p[key::height], key::height);
  return out;
}

nlohmann::json to_json(const Profile& p) {
  nlohmann::json out = {{key::fps, p.fps}};
  if (p.format) out[key::format] = *p.format;
  if (p.width) out[key::width] = *p.width;
  if (p.height) out[key::height] = *p.height;
  return out;
}

Option option_from(const nlohmann::json& o) {
  Option out;
  out.name = text(o, key::name);
  out.value = optional_member(o, key::value);
  out.min = optional_member(o, key::min);
  out.max = optional_member(o, key::max);
  out.step = optional_member(o, key::step);
  out.default_value = optional_member(o, key::default_value);
  if (o.contains(key::description)) out.description = text(o, key::description);
  out.json = array(o, key::json);
  return out;
}

nlohmann::json to_json(const Option& o) {
  nlohmann::json out = {{key::name, o.name}};
  const std::pair<const char*, const nlohmann::json*> optional[] = {
      {key::value, &o.value}, {key::min, &o.min}, {key::max, &o.max}, {key::step, &o.step},
      {key::default_value, &o.default_value}};
  for (const auto& [name, v] : optional)
    if (!v->is_null()) out[name] = *v;
  if (o.description) out[key::description] = *o.description;
  out[key::json] = o.json;
  return out;
}

std::vector<Option> options_from(const nlohmann::json& list) {
  std::vector<Option> out;
  for (const auto& o : list) out.push_back(option_from(o));
  return out;
}

nlohmann::json to_json(const std::vector<Option>& options) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& o : options) out.push_back(to_json(o));
  return out;
}

std::vector<double> numbers(const nlohmann::json& doc, const char* name, std::size_t n) {
  const auto& list = array(doc, name);
  if (list.size() != n) bad(std::string("has a \"") + name + "\" of " + std::to_string(list.size()) + " numbers, not " +
                            std::to_string(n));
  std::vector<double> out;
  for (const auto& x : list) {
    if (!x.is_number()) bad(std::string("has a \"") + name + "\" with something that is not a number");
    out.push_back(x.get<double>());
  }
  return out;
}

}  // namespace

nlohmann::json to_json(const Description& d) {
  nlohmann::json streams = nlohmann::json::array();
  for (const auto& s : d.streams) {
    nlohmann::json profiles = nlohmann::json::array();
    for (const auto& p : s.profiles) profiles.push_back(to_json(p));
    nlohmann::json j = {{key::name, s.name},
                        {key::type, s.type},
                        {key::sensor_name, s.sensor_name},
                        {key::profiles, std::move(profiles)},
                        {key::default_profile, s.default_profile ? to_json(*s.default_profile) : nlohmann::json()},
                        {key::metadata_enabled, s.metadata_enabled},
                        {key::options, to_json(s.options)}};
    if (s.intrinsics) j[key::intrinsics] = *s.intrinsics;
    if (s.embedded_filters) j[key::embedded_filters] = *s.embedded_filters;
    streams.push_back(std::move(j));
  }
  nlohmann::json extrinsics = nlohmann::json::array();
  for (const auto& e : d.extrinsics)
    extrinsics.push_back(
        {{key::from, e.from}, {key::to, e.to}, {key::rotation, e.rotation}, {key::translation, e.translation}});
  return {{key::streams, std::move(streams)},
          {key::device_options, to_json(d.device_options)},
          {key::extrinsics, std::move(extrinsics)},
          {key::presets, d.presets}};
}

Description description_from_json(const nlohmann::json& doc) {
  if (!doc.is_object()) bad("is not a JSON object");
  Description d;
  for (const auto& s : array(doc, key::streams)) {
    Stream st;
    st.name = text(s, key::name);
    st.type = text(s, key::type);
    st.sensor_name = text(s, key::sensor_name);
    for (const auto& p : array(s, key::profiles)) st.profiles.push_back(profile_from(p));
    if (const auto& dp = member(s, key::default_profile); !dp.is_null()) st.default_profile = profile_from(dp);
    const auto& meta = member(s, key::metadata_enabled);
    if (!meta.is_boolean()) bad("has a \"metadata-enabled\" that is not true or false");
    st.metadata_enabled = meta.get<bool>();
    st.options = options_from(array(s, key::options));
    if (s.contains(key::intrinsics)) st.intrinsics = s[key::intrinsics];
    if (s.contains(key::embedded_filters)) st.embedded_filters = s[key::embedded_filters];
    d.streams.push_back(std::move(st));
  }
  d.device_options = options_from(array(doc, key::device_options));
  for (const auto& e : array(doc, key::extrinsics))
    d.extrinsics.push_back({text(e, key::from), text(e, key::to), numbers(e, key::rotation, 9),
                            numbers(e, key::translation, 3)});
  for (const auto& p : array(doc, key::presets)) d.presets.push_back(p);
  return d;
}

}  // namespace rsd::model
