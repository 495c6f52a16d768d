// Server-Sent Events, parsed incrementally by the WHATWG rules the daemon follows:
// lines end in LF, CR or CRLF; ':' starts a comment; a blank line dispatches.
#include "internal.hpp"

namespace rsdiscovery::detail {

void SseParser::feed(std::string_view chunk) {
  if (!bom_checked_ && !chunk.empty()) {
    pending_.append(chunk);
    if (pending_.size() < 3 && std::string_view("\xEF\xBB\xBF").substr(0, pending_.size()) == pending_)
      return;  // maybe a BOM, wait for more
    bom_checked_ = true;
    if (pending_.rfind("\xEF\xBB\xBF", 0) == 0) pending_.erase(0, 3);
    std::string first;
    first.swap(pending_);
    feed(first);
    return;
  }
  std::size_t start = 0;
  for (std::size_t i = 0; i < chunk.size(); ++i) {
    char c = chunk[i];
    if (c != '\n' && c != '\r') continue;
    if (c == '\n' && last_was_cr_ && i == start && pending_.empty()) {  // LF of a CRLF
      last_was_cr_ = false;
      start = i + 1;
      continue;
    }
    pending_.append(chunk.substr(start, i - start));
    std::string text;
    text.swap(pending_);
    last_was_cr_ = c == '\r';
    line(text);
    start = i + 1;
  }
  if (start < chunk.size()) {
    last_was_cr_ = false;
    pending_.append(chunk.substr(start));
    if (pending_.size() > kMaxEvent) too_large();
  }
}

void SseParser::too_large() {
  throw Error(ErrorCode::malformed_reply, "malformed event stream from rs-discoveryd: an event larger than " +
                                              std::to_string(kMaxEvent >> 20) + " MiB (not read)");
}

void SseParser::line(std::string_view text) {
  if (text.empty()) {  // dispatch
    if (has_data_) {
      SseMessage msg;
      msg.event = event_.empty() ? "message" : event_;
      msg.data = data_;
      msg.id = id_;
      msg.has_id = has_id_;
      sink_(std::move(msg));
    } else if (has_id_ && !event_.empty()) {
      // An event with an id and no data (a bare `event: resync`) still matters.
      SseMessage msg;
      msg.event = event_;
      msg.id = id_;
      msg.has_id = true;
      sink_(std::move(msg));
    } else if (!event_.empty()) {
      SseMessage msg;
      msg.event = event_;
      sink_(std::move(msg));
    }
    event_.clear();
    data_.clear();
    id_.clear();
    has_data_ = has_id_ = false;
    return;
  }
  if (text[0] == ':') {
    ++comments_;
    return;
  }
  std::string_view field = text, value;
  if (auto colon = text.find(':'); colon != std::string_view::npos) {
    field = text.substr(0, colon);
    value = text.substr(colon + 1);
    if (!value.empty() && value[0] == ' ') value.remove_prefix(1);
  }
  if (field == "event") {
    event_ = value;
  } else if (field == "data") {
    if (has_data_) data_ += '\n';
    data_.append(value);
    has_data_ = true;
    if (data_.size() > kMaxEvent) too_large();
  } else if (field == "id") {
    if (value.find('\0') == std::string_view::npos) {
      id_ = value;
      has_id_ = true;
    }
  }  // "retry" and unknown fields: ignored
}

}  // namespace rsdiscovery::detail
