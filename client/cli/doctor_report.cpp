// rs-discover doctor's report: the findings as lines (coloured by verdict) or as
// JSON, and the exit status they stand for.
#include "doctor.hpp"

#include <algorithm>
#include <cstdio>

namespace rsdiscover::doctor {
namespace {

const char* verdict_name(Verdict v) {
  switch (v) {
    case Verdict::ok: return "ok";
    case Verdict::info: return "info";
    case Verdict::warn: return "warn";
    case Verdict::fail: return "fail";
  }
  return "?";
}

const char* verdict_color(Verdict v) {
  return v == Verdict::ok ? color::green : v == Verdict::fail ? color::red : v == Verdict::warn ? color::yellow : nullptr;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\u%04x", c);
      out += hex;
      continue;
    }
    out += c;
  }
  return out + "\"";
}

}  // namespace

int Report::print(bool json) const {
  int worst = 0;
  for (const auto& f : findings_) worst = std::max(worst, static_cast<int>(f.verdict));
  if (json) {
    std::string out = "{\"findings\":[";
    for (std::size_t i = 0; i < findings_.size(); ++i) {
      const auto& f = findings_[i];
      out += std::string(i ? "," : "") + "{\"verdict\":\"" + verdict_name(f.verdict) +
           "\",\"topic\":" + json_string(f.topic) + ",\"text\":" + json_string(f.text) + "}";
    }
    std::fputs((out + "]}\n").c_str(), stdout);
  } else {
    for (const auto& f : findings_) {
      char label[8];
      std::snprintf(label, sizeof label, "%-5s", verdict_name(f.verdict));
      std::printf("%s %-10s %s\n", paint(label, verdict_color(f.verdict)).c_str(), f.topic.c_str(), f.text.c_str());
    }
  }
  // 0: nothing found that explains a missing camera; 1: something to fix (a
  // warning or a failure). `info` lines never change it.
  return worst >= static_cast<int>(Verdict::warn) ? kNotFound : kOk;
}

}  // namespace rsdiscover::doctor
