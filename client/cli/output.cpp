// rs-discover's plain output: colour, the columns a device is shown with (state,
// location, addresses, sources, age), ISO 8601 times, and tables like `docker ps`.
#include "common.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>

namespace rsdiscover {

namespace color {
const char* const bold = "\033[1m";
const char* const green = "\033[32m";
const char* const yellow = "\033[33m";
const char* const red = "\033[31m";
const char* const dim = "\033[2m";
}  // namespace color

std::string paint(const std::string& text, const char* code) {
  if (!output().color || !code) return text;
  return code + text + "\033[0m";
}

std::string join(const std::vector<std::string>& parts, const std::string& sep) {
  std::string out;
  for (const auto& p : parts) {
    if (!out.empty()) out += sep;
    out += p;
  }
  return out;
}

std::string device_state(const rsdiscovery::Device& d) { return d.state.empty() ? "ok" : d.state; }

const char* state_color(const std::string& state) {
  if (state == "ok") return color::green;
  if (state == "recovery") return color::yellow;
  return color::red;
}

std::string device_location(const rsdiscovery::Device& d) {
  std::string out;
  const auto part = [&](std::string_view text) { out.append(out.empty() ? "" : ", ").append(text); };
  if (d.domain) part(std::to_string(*d.domain));
  if (d.usb) {
    if (!d.usb->port_path.empty()) part("usb " + d.usb->port_path);
    else part(d.usb->bus ? "usb bus " + std::to_string(*d.usb->bus) : std::string("usb ?"));
  }
  if (const auto host = rsdiscovery::sharing_host(d))
    part("on " + (host->name.empty() ? std::string("?") : host->name));
  return out.empty() ? "-" : out;
}

std::string device_addresses(const rsdiscovery::Device& d) {
  if (const auto host = rsdiscovery::sharing_host(d)) return host->addresses.empty() ? "-" : join(host->addresses, ",");
  if (!d.server || d.server->addresses.empty()) return "-";
  return join(d.server->addresses, ",");
}

std::string device_sources(const rsdiscovery::Device& d) {
  if (d.sources.size() > 1) return join(d.sources, "+");
  return d.source.empty() ? "-" : d.source;
}

std::optional<double> parse_iso8601(const std::string& text) {
  // "2026-11-24T10:09:54.065Z", "+02:00"-style offsets too. By hand, digit by digit,
  // with the chrono calendar: sscanf and timegm, then from_chars, for the AGE column
  // were a large part of a cold `rs-discover list` (callgrind).
  const char* p = text.data();
  const char* const end = p + text.size();
  const auto number = [&](int digits, int& out) {
    if (end - p < digits) return false;
    out = 0;
    for (const char* stop = p + digits; p < stop; ++p) {
      if (*p < '0' || *p > '9') return false;
      out = out * 10 + (*p - '0');
    }
    return true;
  };
  const auto expect = [&](char c) { return p < end && *p++ == c; };
  int y, mo, d, h, mi, whole_s;
  if (!number(4, y) || !expect('-') || !number(2, mo) || !expect('-') || !number(2, d) || !expect('T') ||
      !number(2, h) || !expect(':') || !number(2, mi) || !expect(':') || !number(2, whole_s))
    return std::nullopt;
  const std::chrono::year_month_day date{std::chrono::year{y}, std::chrono::month{static_cast<unsigned>(mo)},
                                         std::chrono::day{static_cast<unsigned>(d)}};
  if (!date.ok() || h > 23 || mi > 59 || whole_s > 60) return std::nullopt;
  double fraction = 0;
  if (p < end && *p == '.') {
    double scale = 0.1;
    for (++p; p < end && *p >= '0' && *p <= '9'; ++p, scale /= 10) fraction += (*p - '0') * scale;
  }
  double offset = 0;  // "Z" or none: UTC
  if (p < end && (*p == '+' || *p == '-')) {
    const int sign = *p++ == '+' ? 1 : -1;
    int oh = 0, om = 0;
    if (!number(2, oh)) return std::nullopt;
    if (p < end && *p == ':') ++p;
    if (p < end) number(2, om);
    offset = sign * (oh * 3600 + om * 60);
  }
  const auto days = std::chrono::sys_days{date}.time_since_epoch().count();
  return static_cast<double>(days) * 86400 + h * 3600 + mi * 60 + whole_s + fraction - offset;
}

std::string age_since(const std::string& iso8601) {
  auto then = parse_iso8601(iso8601);
  if (!then) return "-";
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  double secs = static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) / 1e9 - *then;
  if (secs < 0) secs = 0;
  auto n = static_cast<long long>(secs);
  if (n < 60) return std::to_string(n) + "s";
  if (n < 3600) return std::to_string(n / 60) + "m";
  if (n < 86400) return std::to_string(n / 3600) + "h";
  return std::to_string(n / 86400) + "d";
}

namespace {
// Display width of UTF-8 text: one column per code point (device names are ASCII
// in practice; this keeps any other text from breaking the alignment badly).
std::size_t width(const std::string& s) {
  std::size_t n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}
}  // namespace

void Table::add(std::vector<std::string> cells, std::vector<const char*> colors) {
  for (std::size_t i = 0; i < headers_.size(); ++i)
    cell(i < cells.size() ? std::move(cells[i]) : std::string(), i < colors.size() ? colors[i] : nullptr);
}

void Table::cell(std::string text, const char* color) {
  widths_.push_back(width(text));
  cells_.push_back(std::move(text));
  colors_.push_back(color);
}

void Table::reserve_rows(std::size_t rows) {
  cells_.reserve(rows * headers_.size());
  colors_.reserve(rows * headers_.size());
  widths_.reserve(rows * headers_.size());
}

void Table::print(std::FILE* out) const {
  const std::size_t columns = headers_.size();
  std::vector<std::size_t> header_widths(columns), w(columns);
  for (std::size_t i = 0; i < columns; ++i) w[i] = header_widths[i] = width(headers_[i]);
  for (std::size_t k = 0; k < widths_.size(); ++k) w[k % columns] = std::max(w[k % columns], widths_[k]);
  // The whole table in one buffer, cells appended in place, and one write (a copy of
  // each cell, a string grown per line and a write per line were most of the
  // table's cost in a cold list of 100).
  const bool color = output().color;
  std::string text;
  auto line = [&](const std::string* cells, const std::size_t* widths, const char* const* colors, const char* all) {
    for (std::size_t i = 0; i < columns; ++i) {
      const char* code = colors ? colors[i] : all;
      if (color && code) text.append(code).append(cells[i]).append("\033[0m");
      else text.append(cells[i]);
      if (i + 1 < columns) text.append(w[i] - widths[i] + 2, ' ');
    }
    text += '\n';
  };
  if (output().headers) line(headers_.data(), header_widths.data(), nullptr, color::bold);
  const std::size_t rows = columns ? cells_.size() / columns : 0;
  text.reserve(text.size() * (rows + 1));  // each line about as long as the headers'
  for (std::size_t k = 0; k < rows * columns; k += columns)
    line(cells_.data() + k, widths_.data() + k, colors_.data() + k, nullptr);
  std::fwrite(text.data(), 1, text.size(), out);
}

std::string missing_since(const rsdiscovery::ExpectedCamera& camera) {
  if (camera.last_seen.empty() && camera.reason.empty()) return "never listed since the daemon started";
  std::string text = camera.last_seen.empty() ? "" : "last listed " + age_since(camera.last_seen) + " ago";
  if (!camera.reason.empty()) text += (text.empty() ? "" : ", ") + camera.reason;
  return text;
}

}  // namespace rsdiscover
