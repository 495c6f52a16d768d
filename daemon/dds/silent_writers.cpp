// DomainBook's silent writers: a device-info writer that matched the current
// reader and sent nothing had its server's broadcast lost (it raced discovery, or
// a lossy link ate it); the reader is made anew, which makes every server
// broadcast again. See BookOptions::silent_grace and awaited_silent_grace.
#include "dds/domain_book.hpp"

#include "log/log.hpp"

#include <algorithm>

namespace rsd::dds {

std::set<std::string> DomainBook::awaited_servers() const {
  std::set<std::string> heard;  // servers that announced to the current reader
  for (const auto& [h, w] : writers_)
    if (w.sent) heard.insert(w.identity.participant_guid);
  std::set<std::string> out;
  for (const auto& [guid, n] : per_participant_)
    if (!heard.count(guid)) out.insert(guid);
  for (auto& guid : lost_.participants()) out.insert(std::move(guid));
  return out;
}

std::chrono::milliseconds DomainBook::silent_grace_of(const Writer& w, const std::set<std::string>& awaited) const {
  return awaited.count(w.identity.participant_guid) ? options_.awaited_silent_grace : options_.silent_grace;
}

bool DomainBook::ask_silent_servers_again(Clock::time_point now) {
  const auto quiet = [&](const Writer& w) {
    return !w.sent && now - w.matched_at >= options_.awaited_silent_grace && !idle_writers_.count(w.identity.guid);
  };
  if (std::none_of(writers_.begin(), writers_.end(), [&](const auto& hw) { return quiet(hw.second); }))
    return false;  // the common case, worked out without a set of servers
  const auto awaited = awaited_servers();
  // Per server, the writers that matched a while ago and sent nothing, but for
  // those already known to be idle.
  std::map<std::string, std::vector<std::string>> silent;  // participant GUID -> such writers
  for (const auto& [h, w] : writers_) {
    if (w.sent || now - w.matched_at < silent_grace_of(w, awaited) || idle_writers_.count(w.identity.guid)) continue;
    // Silent for the new reader too: it never writes, unless it announced a device or
    // its server is awaited (its broadcast was lost twice, as on a lossy link).
    const bool waited_for = awaited.count(w.identity.participant_guid) > 0;
    if (retried_writers_.erase(w.identity.guid) && !waited_for && !devices_of_writer_.count(w.identity.guid)) {
      // Named first: clang before 16 cannot capture a structured binding.
      const std::string& guid = w.identity.guid;
      log::debug([&] { return prefix() + "writer " + guid + " stayed silent for a new reader: idle"; });
      idle_writers_.insert(w.identity.guid);
      continue;
    }
    silent[w.identity.participant_guid].push_back(w.identity.guid);
  }
  bool anew = false;
  for (const auto& [p, guids] : silent) {
    // Announcing to this reader already: its one silent writer is most likely idle.
    const bool announces = per_participant_.count(p) > 0 && !awaited.count(p);
    if (guids.size() < 2 && announces) continue;
    int& retries = silent_retries_[p];
    if (retries >= (awaited.count(p) ? options_.awaited_silent_retries : options_.silent_retries)) continue;
    ++retries;
    retried_writers_.insert(guids.begin(), guids.end());
    log::info(prefix() + "server " + p + " has " + std::to_string(guids.size()) +
              " writer(s) that matched but sent no device-info; making the reader anew so it "
              "broadcasts again (try " + std::to_string(retries) + ")");
    anew = true;
  }
  return anew;
}

}  // namespace rsd::dds
