#include "service/domain_set.hpp"

#include "log/log.hpp"

#include <algorithm>
#include <set>

namespace rsd::service {

DomainSet::DomainSet(SharedTable& table, dds::SessionOptions base) : table_(table), base_(std::move(base)) {
  base_.wake = [this] { wake_.wake(); };
}

DomainSet::~DomainSet() { stop(); }

std::shared_ptr<dds::DomainSession> DomainSet::make(int domain) const {
  dds::SessionOptions options = base_;
  options.domain = domain;
  options.describe_eagerly = options.describe_eagerly || options.describe_eagerly_in.count(domain) > 0;
  auto session = std::make_shared<dds::DomainSession>(table_, options);
  session->share_usb(usb_cameras_);  // announced once its participant is made
  return session;
}

void DomainSet::start(const std::vector<int>& domains) {
  for (int d : domains) {
    if (sessions_.count(d)) continue;
    auto session = make(d);
    session->start();  // throws: the caller gives up
    std::lock_guard lock(mutex_);
    sessions_.emplace(d, std::move(session));
    ++set_version_;
  }
}

DomainSet::Change DomainSet::apply(const std::vector<int>& domains) {
  Change change;
  const std::set<int> wanted(domains.begin(), domains.end());
  // Leave first: a domain dropped and another added in one reload never has
  // both participants alive at once.
  std::vector<std::shared_ptr<dds::DomainSession>> leaving;
  {
    std::lock_guard lock(mutex_);
    for (auto it = sessions_.begin(); it != sessions_.end();) {
      if (wanted.count(it->first)) {
        ++it;
        continue;
      }
      change.left.push_back(it->first);
      leaving.push_back(std::move(it->second));
      it = sessions_.erase(it);
      ++set_version_;
    }
  }
  for (auto& s : leaving) {
    s->stop();            // DDS entities gone: no listener can add a device after this
    s->forget_devices(model::RemovalReason::domain_left);  // then its devices leave the table
    log::notice(log::domain_prefix(s->domain()) + "left (no longer configured)");
  }
  for (int d : wanted) {
    if (sessions_.count(d)) continue;
    auto session = make(d);
    try {
      session->start();
    } catch (const std::exception& e) {
      change.failed.push_back(log::domain_prefix(d) + e.what());
      log::error(log::domain_prefix(d) + "cannot join: " + e.what());
      continue;
    }
    change.joined.push_back(d);
    std::lock_guard lock(mutex_);
    sessions_.emplace(d, std::move(session));
    ++set_version_;
  }
  return change;
}

void DomainSet::rebuild() {
  for (auto& [d, s] : sessions_) {
    try {
      s->rebuild();
    } catch (const std::exception& e) {
      log::error(e.what());
    }
  }
}

void DomainSet::follow_network(const std::vector<net::NetInterface>& chosen) {
  base_.interfaces = chosen;
  for (auto& [d, s] : sessions_) {
    try {
      s->follow_network(chosen);
    } catch (const std::exception& e) {  // the session says failed; the next change tries again
      log::error(e.what());
    }
  }
}

void DomainSet::stop() {
  for (auto& [d, s] : sessions_) s->stop();
}

void DomainSet::set_device_caps(std::size_t per_participant, std::size_t per_domain) {
  base_.book.max_devices_per_participant = per_participant;
  base_.book.max_devices_per_domain = per_domain;
  for (auto& [d, s] : sessions_) s->set_device_caps(per_participant, per_domain);
}

void DomainSet::share_usb(const std::map<std::string, nlohmann::json>& cameras) {
  usb_cameras_ = cameras;
  for (auto& [d, s] : sessions_) s->share_usb(cameras);
}

DomainSet::Clock::duration DomainSet::tick(Clock::time_point now) {
  Clock::duration wait = dds::DomainSession::kIdle;
  for (auto& [d, s] : sessions_) wait = std::min(wait, s->tick(now));
  return wait;
}

std::vector<int> DomainSet::ids() const {
  std::vector<int> out;
  for (const auto& [d, s] : sessions_) out.push_back(d);
  return out;
}

bool DomainSet::all_reading() const {
  return std::all_of(sessions_.begin(), sessions_.end(), [](const auto& e) { return e.second->reading(); });
}

std::vector<DomainStatus> DomainSet::status() const {
  std::lock_guard lock(mutex_);
  std::vector<DomainStatus> out;
  for (const auto& [d, s] : sessions_) out.push_back(s->status());
  return out;
}

std::vector<model::Participant> DomainSet::participants() const {
  std::lock_guard lock(mutex_);
  std::vector<model::Participant> out;
  for (const auto& [d, s] : sessions_) {
    auto some = s->participants();
    out.insert(out.end(), std::make_move_iterator(some.begin()), std::make_move_iterator(some.end()));
  }
  return out;
}

bool DomainSet::discovery_complete() const {
  const auto version = set_version_.load();
  if (complete_version_.load() == version) return true;
  std::lock_guard lock(mutex_);
  for (const auto& [d, s] : sessions_)
    if (!s->discovery_complete()) return false;
  complete_version_ = version;  // a set changed meanwhile has a newer version: asked again
  return true;
}

std::optional<model::DeviceClients> DomainSet::clients(int domain, const std::string& topic_root) const {
  std::shared_ptr<dds::DomainSession> session;
  {
    std::lock_guard lock(mutex_);
    if (auto it = sessions_.find(domain); it != sessions_.end()) session = it->second;
  }
  if (!session) return std::nullopt;
  return session->clients(topic_root);
}

DeviceDescription DomainSet::describe(const std::string& id, std::chrono::milliseconds wait) const {
  using Outcome = DeviceDescription::Outcome;
  const auto device = table_.find(id);
  if (!device) return {Outcome::not_found, nullptr, "no device '" + id + "'"};
  const auto domain = device->find("domain");
  const auto topic_root = device->find("topic-root");
  if (domain == device->end() || !domain->is_number_integer() || topic_root == device->end() ||
      !topic_root->is_string())
    return {Outcome::not_network, nullptr,
            "'" + id + "' is a USB camera: only network (realdds) cameras describe themselves without being opened"};
  if (device->value("recovery", false))
    return {Outcome::recovery, nullptr, "'" + id + "' runs its recovery firmware: it has no streams to describe"};
  std::shared_ptr<dds::DomainSession> session;
  {
    std::lock_guard lock(mutex_);
    if (auto it = sessions_.find(domain->get<int>()); it != sessions_.end()) session = it->second;
  }
  if (!session) return {Outcome::not_found, nullptr, "no device '" + id + "'"};
  const auto result = session->describe(topic_root->get<std::string>(), wait);
  if (!result) return {Outcome::not_found, nullptr, "no device '" + id + "'"};
  switch (result->outcome) {
    case dds::DescribeResult::Outcome::ok:
      return {Outcome::ok, result->description, ""};
    case dds::DescribeResult::Outcome::timeout:
      return {Outcome::timeout, nullptr, result->error};
    case dds::DescribeResult::Outcome::gone:
      return {Outcome::not_found, nullptr, "'" + id + "' left while it was being described"};
    case dds::DescribeResult::Outcome::unavailable:
      break;
  }
  return {Outcome::unavailable, nullptr, result->error};
}

}  // namespace rsd::service
