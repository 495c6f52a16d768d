// GET /v1/devices' reply into a DeviceList: parsed by nlohmann (as every other reply)
// under a bound on nesting, and read by the model's one device reader.
#include "internal.hpp"

#include <cstdint>

namespace rsdiscovery::detail {

namespace {

using nlohmann::json;

// nlohmann's own tree builder with a bound on nesting: the parse itself does not
// recurse, but a key the model does not know is written out again (dump) and that
// does; no list of the daemon's comes near the bound (a device-info is cut at 16
// levels: daemon/dds/device_info.hpp).
class DepthLimited : public nlohmann::detail::json_sax_dom_parser<json> {
 public:
  static constexpr int kMaxDepth = 64;
  explicit DepthLimited(json& tree) : json_sax_dom_parser(tree, false) {}
  bool too_deep() const { return too_deep_; }
  bool start_object(std::size_t n) { return enter() && json_sax_dom_parser::start_object(n); }
  bool end_object() { return leave() && json_sax_dom_parser::end_object(); }
  bool start_array(std::size_t n) { return enter() && json_sax_dom_parser::start_array(n); }
  bool end_array() { return leave() && json_sax_dom_parser::end_array(); }

 private:
  bool enter() {
    too_deep_ = ++depth_ > kMaxDepth;
    return !too_deep_;
  }
  bool leave() {
    --depth_;
    return true;
  }
  int depth_ = 0;
  bool too_deep_ = false;
};

}  // namespace

std::optional<std::string> read_device_list(std::string& body, const std::string& path, DeviceList& out) {
  // JSON has no NUL outside strings, nor raw inside them; nlohmann stops at one as at
  // the end of the text.
  if (body.find('\0') != std::string::npos) return "GET " + path + " did not return a JSON object";
  json doc;
  DepthLimited builder(doc);
  const bool parsed = json::sax_parse(body, &builder);
  if (builder.too_deep())
    return "GET " + path + " returned a document nested deeper than " + std::to_string(DepthLimited::kMaxDepth) +
           " levels";
  if (!parsed || !doc.is_object()) return "GET " + path + " did not return a JSON object";
  const auto devices = doc.find("devices");
  if (devices == doc.end() || !devices->is_array()) return "no \"devices\" array";
  // Each device's text as the daemon sent it, when the scan finds as many as the parser.
  auto texts = array_member_elements(body, "devices");
  const bool texts_fit = texts.size() == devices->size();
  out.devices.clear();
  out.devices.reserve(devices->size());
  for (const auto& d : *devices) {
    if (!d.is_object()) return "a device is not a JSON object";
    const std::size_t i = out.devices.size();
    out.devices.push_back(device_from_model(rsd::model::device_from_json(d),
                                            texts_fit ? std::string(texts[i]) : d.dump()));
  }
  // nlohmann holds every integer from 0 up as unsigned: a negative one is refused.
  if (const auto g = doc.find("generation"); g != doc.end() && g->is_number_unsigned())
    out.generation = g->get<std::uint64_t>();
  out.complete = reports_complete(doc);
  return std::nullopt;
}

}  // namespace rsdiscovery::detail
