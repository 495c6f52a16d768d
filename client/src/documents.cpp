// The daemon's status documents (domains, participants, a camera's clients, health,
// expected cameras, a camera's description) read into the public types. Strict on
// what a type holds: a missing or mistyped key of it is a malformed reply naming the
// key and the document; keys the types do not hold are left to their `json` text.
// The keys are the daemon's own spelling (rsd_model/spelling.hpp).
#include "internal.hpp"

#include "rsd_model/spelling.hpp"

namespace rsdiscovery::detail {

namespace {

namespace model = rsd::model;

[[noreturn]] void malformed(const std::string& what) {
  throw Error(ErrorCode::malformed_reply, "malformed reply from rs-discoveryd: " + what);
}

// One JSON object of a document, read strictly; `what` names it in errors.
class Strict {
 public:
  Strict(const json::Value& v, std::string what) : v_(v), what_(std::move(what)) {
    if (!v.IsObject()) malformed(what_ + " is not a JSON object");
  }
  bool has(const char* name) const { return json::find(v_, name) != nullptr; }
  const json::Value& member(const char* name) const {
    const auto* v = json::find(v_, name);
    if (!v) malformed(what_ + " has no \"" + name + "\"");
    return *v;
  }
  std::string text(const char* name) const {
    auto t = json::text(&member(name));
    if (!t) malformed(what_ + ": \"" + name + "\" is not a string");
    return std::string(*t);
  }
  std::string text_or(const char* name, std::string fallback = {}) const {
    return has(name) ? text(name) : std::move(fallback);
  }
  std::uint64_t count(const char* name) const { return count_of(member(name), name); }
  std::uint64_t count_of(const json::Value& v, const std::string& name) const {
    auto n = json::unsigned_integer(&v);
    if (!n) malformed(what_ + ": \"" + name + "\" is not a count");
    return *n;
  }
  bool flag(const char* name) const {
    auto b = json::boolean(&member(name));
    if (!b) malformed(what_ + ": \"" + name + "\" is not true or false");
    return *b;
  }
  std::vector<std::string> texts(const char* name) const {
    const auto& v = member(name);
    if (!v.IsArray()) malformed(what_ + ": \"" + name + "\" is not an array");
    for (const auto& item : v.GetArray())
      if (!item.IsString()) malformed(what_ + ": \"" + name + "\" holds a non-string");
    return json::texts(&v);
  }
  // name -> count, for an object of counts.
  std::map<std::string, std::uint64_t> counts(const char* name) const {
    const auto& v = member(name);
    if (!v.IsObject()) malformed(what_ + "'s \"" + name + "\" is not an object");
    std::map<std::string, std::uint64_t> out;
    for (const auto& m : v.GetObject()) {
      std::string key(m.name.GetString(), m.name.GetStringLength());
      out[key] = count_of(m.value, key);
    }
    return out;
  }
  int domain_id(const char* name) const {
    auto d = json::integer(&member(name));
    if (!d || *d < 0 || *d > 232) malformed(what_ + "'s \"" + name + "\" is not a domain id");
    return static_cast<int>(*d);
  }
  // A name of an enum of the API, checked against it.
  template <class Parse>
  std::string name_of(const char* name, Parse parse) const {
    auto t = text(name);
    if (!parse(t)) malformed(what_ + " has an unknown " + name + " '" + t + "'");
    return t;
  }
  const std::string& what() const { return what_; }

 private:
  const json::Value& v_;
  std::string what_;
};

const json::Value& list_of(const json::Value& doc, const char* name, const char* what) {
  const auto* v = json::find(doc, name);
  if (!v || !v->IsArray()) malformed(std::string(what) + " has no \"" + name + "\" list");
  return *v;
}

StreamProfile profile_from(const json::Value& v) {
  Strict p(v, "a description's profile");
  const auto whole = [&](const char* name) {
    auto n = json::integer(&p.member(name));
    if (!n || *n < 0 || *n > std::numeric_limits<int>::max()) malformed("a description's profile has a \"" +
                                                                          std::string(name) + "\" that is not a whole number");
    return static_cast<int>(*n);
  };
  StreamProfile out;
  out.fps = whole(model::description_key::fps);
  out.format = p.text_or(model::description_key::format);
  if (p.has(model::description_key::width)) out.width = whole(model::description_key::width);
  if (p.has(model::description_key::height)) out.height = whole(model::description_key::height);
  return out;
}

std::vector<CameraOption> options_from(const json::Value& list) {
  std::vector<CameraOption> out;
  if (!list.IsArray()) malformed("a description's options are not a list");
  for (const auto& o : list.GetArray()) {
    Strict option(o, "a description's option");
    const auto* value = json::find(o, model::description_key::value);
    const auto& declared = option.member(model::description_key::json);
    if (!declared.IsArray()) malformed("a description's option has a \"json\" that is not a list");
    out.push_back({option.text(model::description_key::name),
                   value && !value->IsNull() ? json::dump(*value) : std::string(),
                   option.text_or(model::description_key::description), json::dump(declared)});
  }
  return out;
}

}  // namespace

Description description_from_json(const json::Value& doc, std::string text) {
  namespace key = model::description_key;
  Strict d(doc, "a description");
  Description out;
  for (const auto& s : list_of(doc, key::streams, "a description").GetArray()) {
    Strict stream(s, "a description's stream");
    CameraStream st;
    st.name = stream.text(key::name);
    st.type = stream.text(key::type);
    st.sensor = stream.text(key::sensor_name);
    for (const auto& p : list_of(s, key::profiles, "a description's stream").GetArray())
      st.profiles.push_back(profile_from(p));
    if (const auto* p = json::find(s, key::default_profile); p && !p->IsNull()) st.default_profile = profile_from(*p);
    st.metadata = stream.flag(key::metadata_enabled);
    st.options = options_from(stream.member(key::options));
    out.streams.push_back(std::move(st));
  }
  out.device_options = options_from(d.member(key::device_options));
  out.json = text.empty() ? json::dump(doc) : std::move(text);
  return out;
}

DomainStatus domain_from_json(const json::Value& doc) {
  namespace key = model::status_key;
  Strict d(doc, "a domain entry");
  DomainStatus s;
  s.domain = d.domain_id(key::domain);
  s.state = d.name_of(key::state, model::parse_domain_state);
  s.participant_guid = d.text(key::participant_guid);
  s.devices = d.count(key::devices);
  s.accepted = d.count(key::accepted);
  s.rejected = d.counts(key::rejected);
  s.complete = d.flag(key::complete);
  s.json = json::dump(doc);
  return s;
}

namespace {

// A DDS peer's identity, in a participant entry and in a camera's client alike.
template <class Peer>
void read_peer(const Strict& d, Peer& p) {
  namespace key = model::peer_key;
  p.guid = d.text(key::guid);
  p.name = d.text(key::name);
  // A vendor this client does not know yet (a newer daemon's) reads as "other".
  const auto vendor = d.text(key::vendor);
  p.vendor = model::parse_vendor(vendor) ? vendor : std::string(model::to_string(model::Vendor::other));
  p.addresses = d.texts(key::addresses);
  p.host = d.text_or(key::host);
  p.process = d.text_or(key::process);
}

}  // namespace

CameraClients clients_from_json(const json::Value& doc) {
  namespace key = model::clients_key;
  Strict d(doc, "a device's clients");
  CameraClients out;
  for (const auto& c : list_of(doc, key::clients, "a device's clients").GetArray()) {
    Strict entry(c, "a client entry");
    CameraClient client;
    read_peer(entry, client);
    client.since = entry.text(key::since);
    client.streams = entry.texts(key::streams);
    if (entry.has(key::ros_nodes)) client.ros_nodes = entry.texts(key::ros_nodes);
    out.clients.push_back(std::move(client));
  }
  out.streams = d.counts(key::streams);
  out.json = json::dump(doc);
  return out;
}

Participant participant_from_json(const json::Value& doc) {
  namespace key = model::participant_key;
  Strict d(doc, "a participant entry");
  Participant p;
  p.domain = d.domain_id(key::domain);
  read_peer(d, p);
  if (d.has(key::lease_seconds)) {
    auto lease = json::number(&d.member(key::lease_seconds));
    if (!lease) malformed("a participant entry's \"lease-seconds\" is not a number");
    p.lease_seconds = *lease;
  }
  p.state = d.name_of(key::state, model::parse_participant_state);
  p.first_seen = d.text(key::first_seen);
  p.last_seen = d.text(key::last_seen);
  p.device_info_writers = d.count(key::device_info_writers);
  p.devices = d.count(key::devices);
  p.never_announced = d.flag(key::never_announced);
  p.topic_roots = d.texts(key::topic_roots);
  p.endpoints = d.count(key::endpoints);
  p.json = json::dump(doc);
  return p;
}

Health health_from_json(const json::Value& doc) {
  namespace key = model::status_key;
  Strict d(doc, "/healthz");
  Health h;
  h.status = d.text(key::status);
  h.version = d.text(key::version);
  h.devices = d.count(key::devices);
  h.complete = d.flag(key::complete);
  h.json = json::dump(doc);
  return h;
}

Expected expected_from_json(const json::Value& doc) {
  namespace key = model::expected_key;
  Strict d(doc, "an expected list");
  const auto list = [&](const char* which) {
    std::vector<ExpectedCamera> out;
    const auto& entries = d.member(which);
    if (!entries.IsArray()) malformed(std::string("an expected list's \"") + which + "\" is not a list");
    for (const auto& e : entries.GetArray()) {
      Strict camera(e, "an expected camera");
      ExpectedCamera c{camera.text_or(key::name), camera.text_or(key::serial), camera.text_or(key::topic_root),
                       camera.text_or(key::id),   camera.text_or(key::last_seen), camera.text_or(key::reason)};
      if (c.serial.empty() && c.topic_root.empty())
        malformed("an expected camera has neither a serial nor a topic-root");
      out.push_back(std::move(c));
    }
    return out;
  };
  Expected e;
  e.complete = d.flag(key::complete);
  e.present = list(key::present);
  e.missing = list(key::missing);
  e.json = json::dump(doc);
  return e;
}

}  // namespace rsdiscovery::detail
