// A camera's description read (the daemon's fetch gives it) and written (rsd_model/description.hpp).
#include "rsd_model/description.hpp"

namespace rsd::model {

namespace {


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
  out.fps = whole(member(p, description_key::fps), description_key::fps);
  if (p.contains(description_key::format)) out.format = text(p, description_key::format);
  if (p.contains(description_key::width)) out.width = whole(p[description_key::width], description_key::width);
  if (p.contains(description_key::height)) out.height = whole(p[description_key::height], description_key::height);
  return out;
}

nlohmann::json to_json(const Profile& p) {
  nlohmann::json out = {{description_key::fps, p.fps}};
  if (p.format) out[description_key::format] = *p.format;
  if (p.width) out[description_key::width] = *p.width;
  if (p.height) out[description_key::height] = *p.height;
  return out;
}

Option option_from(const nlohmann::json& o) {
  Option out;
  out.name = text(o, description_key::name);
  out.value = optional_member(o, description_key::value);
  out.min = optional_member(o, description_key::min);
  out.max = optional_member(o, description_key::max);
  out.step = optional_member(o, description_key::step);
  out.default_value = optional_member(o, description_key::default_value);
  if (o.contains(description_key::description)) out.description = text(o, description_key::description);
  out.json = array(o, description_key::json);
  return out;
}

nlohmann::json to_json(const Option& o) {
  nlohmann::json out = {{description_key::name, o.name}};
  const std::pair<const char*, const nlohmann::json*> optional[] = {
      {description_key::value, &o.value}, {description_key::min, &o.min}, {description_key::max, &o.max}, {description_key::step, &o.step},
      {description_key::default_value, &o.default_value}};
  for (const auto& [name, v] : optional)
    if (!v->is_null()) out[name] = *v;
  if (o.description) out[description_key::description] = *o.description;
  out[description_key::json] = o.json;
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
    nlohmann::json j = {{description_key::name, s.name},
                        {description_key::type, s.type},
                        {description_key::sensor_name, s.sensor_name},
                        {description_key::profiles, std::move(profiles)},
                        {description_key::default_profile, s.default_profile ? to_json(*s.default_profile) : nlohmann::json()},
                        {description_key::metadata_enabled, s.metadata_enabled},
                        {description_key::options, to_json(s.options)}};
    if (s.intrinsics) j[description_key::intrinsics] = *s.intrinsics;
    if (s.embedded_filters) j[description_key::embedded_filters] = *s.embedded_filters;
    streams.push_back(std::move(j));
  }
  nlohmann::json extrinsics = nlohmann::json::array();
  for (const auto& e : d.extrinsics)
    extrinsics.push_back(
        {{description_key::from, e.from}, {description_key::to, e.to}, {description_key::rotation, e.rotation}, {description_key::translation, e.translation}});
  return {{description_key::streams, std::move(streams)},
          {description_key::device_options, to_json(d.device_options)},
          {description_key::extrinsics, std::move(extrinsics)},
          {description_key::presets, d.presets}};
}

Description description_from_json(const nlohmann::json& doc) {
  if (!doc.is_object()) bad("is not a JSON object");
  Description d;
  for (const auto& s : array(doc, description_key::streams)) {
    Stream st;
    st.name = text(s, description_key::name);
    st.type = text(s, description_key::type);
    st.sensor_name = text(s, description_key::sensor_name);
    for (const auto& p : array(s, description_key::profiles)) st.profiles.push_back(profile_from(p));
    if (const auto& dp = member(s, description_key::default_profile); !dp.is_null()) st.default_profile = profile_from(dp);
    const auto& meta = member(s, description_key::metadata_enabled);
    if (!meta.is_boolean()) bad("has a \"metadata-enabled\" that is not true or false");
    st.metadata_enabled = meta.get<bool>();
    st.options = options_from(array(s, description_key::options));
    if (s.contains(description_key::intrinsics)) st.intrinsics = s[description_key::intrinsics];
    if (s.contains(description_key::embedded_filters)) st.embedded_filters = s[description_key::embedded_filters];
    d.streams.push_back(std::move(st));
  }
  d.device_options = options_from(array(doc, description_key::device_options));
  for (const auto& e : array(doc, description_key::extrinsics))
    d.extrinsics.push_back({text(e, description_key::from), text(e, description_key::to), numbers(e, description_key::rotation, 9),
                            numbers(e, description_key::translation, 3)});
  for (const auto& p : array(doc, description_key::presets)) d.presets.push_back(p);
  return d;
}

}  // namespace rsd::model
