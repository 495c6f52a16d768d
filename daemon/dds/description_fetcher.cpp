#include "dds/description_fetcher.hpp"

#include "dds/device_info.hpp"
#include "dds/flexible_topic.hpp"
#include "dds/take_batches.hpp"
#include "log/log.hpp"

#include "flexible.h"

#include <array>
#include <utility>

namespace rsd::dds {

DescriptionFetcher::DescriptionFetcher(int domain, std::chrono::milliseconds fetch_timeout,
                                       std::function<void(const std::string& topic_root, const Readiness&)> readiness)
    : domain_(domain), fetch_timeout_(fetch_timeout), readiness_(std::move(readiness)) {}

DescriptionFetcher::~DescriptionFetcher() {
  set_participant(0);
  tick(Clock::now(), [](const std::string&) { return true; });
}

void DescriptionFetcher::set_participant(dds_entity_t participant) {
  participant_.store(participant);
  if (participant != 0) return;
  std::vector<std::shared_ptr<Fetch>> ending;
  {
    std::lock_guard lock(mutex_);
    for (auto& [root, fetch] : fetches_) {
      fetch->done = true;
      fetch->result = {DescribeResult::Outcome::unavailable, nullptr,
                       "the domain's DDS participant is being made anew; ask again in a few seconds", ""};
      ending.push_back(fetch);
    }
    fetches_.clear();
    ending.insert(ending.end(), finished_.begin(), finished_.end());
    finished_.clear();
  }
  changed_.notify_all();
  for (auto& fetch : ending) unsubscribe(*fetch);  // before the participant goes
}

bool DescriptionFetcher::subscribe(Fetch& fetch, dds_entity_t participant) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  // A whole set is 2 + 2 per stream messages, sent at once; two clients
  // subscribing together make two sets. Bounded all the same.
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 256);
  const std::string name = fetch.topic_root + "/notification";
  const dds_entity_t topic = create_flexible_topic(participant, name.c_str(), qos);
  dds_entity_t reader = -1;
  if (topic > 0) {
    dds_listener_t* listener = dds_create_listener(&fetch);
    dds_lset_data_available(listener, &DescriptionFetcher::on_data);
    reader = dds_create_reader(participant, topic, qos, listener);
    dds_delete_listener(listener);
  }
  dds_delete_qos(qos);
  if (reader < 0) {
    if (topic > 0) dds_delete(topic);
    return false;
  }
  bool ended;
  {
    std::lock_guard lock(mutex_);
    fetch.topic = topic;
    fetch.reader = reader;
    ended = fetch.done;  // the participant went meanwhile
  }
  if (ended) unsubscribe(fetch);
  return true;
}

void DescriptionFetcher::unsubscribe(Fetch& fetch) {
  dds_entity_t reader, topic;
  {
    std::lock_guard lock(mutex_);
    reader = std::exchange(fetch.reader, 0);
    topic = std::exchange(fetch.topic, 0);
  }
  // Deleting the reader waits for a listener still running on it; none of our
  // locks is held here, so that listener can finish.
  if (reader > 0) {
    dds_set_listener(reader, nullptr);
    dds_delete(reader);
  }
  if (topic > 0) dds_delete(topic);
}

std::shared_ptr<DescriptionFetcher::Fetch> DescriptionFetcher::begin(const std::string& topic_root,
                                                                     const nlohmann::json& announcement,
                                                                     DescribeResult& answer) {
  const dds_entity_t participant = participant_.load();
  std::shared_ptr<Fetch> fetch;
  {
    std::lock_guard lock(mutex_);
    if (auto kept = kept_.find(topic_root); kept != kept_.end()) {
      if (kept->second.announcement == announcement) {
        answer = {DescribeResult::Outcome::ok, kept->second.description, "", ""};
        return nullptr;
      }
      kept_.erase(kept);  // announced anew since: its streams may differ
    }
    if (participant == 0) {
      answer = {DescribeResult::Outcome::unavailable, nullptr,
                "the domain has no DDS participant now (starting or being made anew); ask again in a few seconds", ""};
      return nullptr;
    }
    auto& slot = fetches_[topic_root];
    if (slot) return slot;  // under way: share it
    slot = std::make_shared<Fetch>();
    slot->topic_root = topic_root;
    slot->announcement = announcement;
    slot->deadline = Clock::now() + fetch_timeout_;
    slot->ready_deadline = Clock::now() + kLibrealsenseReadyWait;
    slot->owner = this;
    fetch = slot;
  }
  ++started_;
  log::debug([&] { return log::domain_prefix(domain_) + "subscribing to " + topic_root + "/notification"; });
  if (!subscribe(*fetch, participant)) {
    std::lock_guard lock(mutex_);
    if (!fetch->done) {
      fetch->done = true;
      fetch->result = {DescribeResult::Outcome::unavailable, nullptr,
                       "cannot subscribe to " + topic_root + "/notification", ""};
      if (auto it = fetches_.find(topic_root); it != fetches_.end() && it->second == fetch) fetches_.erase(it);
    }
    changed_.notify_all();
  }
  return fetch;
}

DescribeResult DescriptionFetcher::describe(const std::string& topic_root, const nlohmann::json& announcement,
                                            std::chrono::milliseconds wait) {
  const auto until = Clock::now() + wait;
  DescribeResult answer;
  const auto fetch = begin(topic_root, announcement, answer);
  if (!fetch) return answer;
  std::unique_lock lock(mutex_);
  changed_.wait_until(lock, std::min(until, fetch->deadline), [&] { return fetch->done; });
  if (fetch->done) return fetch->result;
  return {DescribeResult::Outcome::timeout, nullptr,
          "the camera's server sent no complete description within " +
              std::to_string(std::chrono::duration_cast<std::chrono::seconds>(wait).count()) +
              " s (it got as far as: " + fetch->assembler.stage() + ")",
          fetch->assembler.stage()};
}

void DescriptionFetcher::prefetch(const std::string& topic_root, const nlohmann::json& announcement) {
  {
    std::lock_guard lock(mutex_);
    if (auto tried = prefetched_.find(topic_root); tried != prefetched_.end() && tried->second.announcement == announcement)
      return;
    prefetched_[topic_root] = Tried{announcement, std::nullopt, kRetryFirst};
  }
  DescribeResult answer;
  begin(topic_root, announcement, answer);
}

void DescriptionFetcher::on_data(dds_entity_t reader, void* arg) {
  auto* fetch = static_cast<Fetch*>(arg);
  try {
    fetch->owner->take(*fetch, reader);
  } catch (const std::exception& e) {  // never across Cyclone's C threads
    log::error(std::string("notification listener: ") + e.what());
  }
}

void DescriptionFetcher::take(Fetch& fetch, dds_entity_t reader) {
  bool completed = false;
  take_batches(reader, [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
    {
      std::lock_guard lock(mutex_);
      for (std::size_t i = 0; i < samples.size() && !fetch.done; ++i) {
        if (!infos[i].valid_data) continue;
        const auto* msg = static_cast<const realdds_topics_raw_flexible*>(samples[i]);
        auto parsed = parse_flexible(static_cast<std::int32_t>(msg->data_format),
                                     std::span<const std::uint8_t>(msg->data._buffer, msg->data._length));
        std::string reason;
        if (auto* bad = std::get_if<Rejected>(&parsed)) reason = bad->reason;
        else reason = fetch.assembler.add(std::get<nlohmann::json>(parsed));
        if (!reason.empty()) {
          ++rejected_["notification-" + reason];
          continue;
        }
        if (fetch.assembler.step() == DescriptionAssembler::Step::complete) {
          fetch.done = true;
          fetch.result = {DescribeResult::Outcome::ok, fetch.assembler.description(), "", ""};
          kept_[fetch.topic_root] = {fetch.announcement, fetch.result.description};
          if (auto it = fetches_.find(fetch.topic_root); it != fetches_.end() && it->second.get() == &fetch) {
            finished_.push_back(it->second);  // its reader goes on the main thread's next tick
            fetches_.erase(it);
          }
          completed = true;
        }
      }
    }
  });
  if (completed) {
    log::info(log::domain_prefix(domain_) + "described " + fetch.topic_root);
    changed_.notify_all();
    if (readiness_) readiness_(fetch.topic_root, Readiness{true, ""});
  }
}

void DescriptionFetcher::tick(Clock::time_point now,
                              const std::function<bool(const std::string& topic_root)>& still_there) {
  std::vector<std::shared_ptr<Fetch>> ending;
  std::vector<std::pair<std::string, Readiness>> not_ready;
  std::vector<std::pair<std::string, nlohmann::json>> retries;
  bool expired = false;
  {
    std::lock_guard lock(mutex_);
    for (auto it = fetches_.begin(); it != fetches_.end();) {
      Fetch& f = *it->second;
      if (!still_there(f.topic_root)) {
        f.done = true;
        f.result = {DescribeResult::Outcome::gone, nullptr, "the device left while it was being described", ""};
        finished_.push_back(it->second);
        it = fetches_.erase(it);
        expired = true;
        continue;
      }
      if (now >= f.ready_deadline && !f.told_not_ready) {
        f.told_not_ready = true;  // librealsense would have given the device up by now
        not_ready.emplace_back(f.topic_root, Readiness{false, f.assembler.stage()});
      }
      if (now < f.deadline) {
        ++it;
        continue;
      }
      f.done = true;
      f.result = {DescribeResult::Outcome::timeout, nullptr,
                  "the camera's server sent no complete description within " +
                      std::to_string(std::chrono::duration_cast<std::chrono::seconds>(fetch_timeout_).count()) +
                      " s (it got as far as: " + f.assembler.stage() + ")",
                  f.assembler.stage()};
      log::warning(log::domain_prefix(domain_) + "no complete description from " + f.topic_root +
                   " (it got as far as: " + f.assembler.stage() + ")");
      not_ready.emplace_back(f.topic_root, Readiness{false, f.assembler.stage()});
      if (auto tried = prefetched_.find(f.topic_root);
          tried != prefetched_.end() && tried->second.announcement == f.announcement) {
        tried->second.retry_at = now + tried->second.backoff;
        tried->second.backoff = std::min<Clock::duration>(tried->second.backoff * 2, kRetryMost);
      }
      finished_.push_back(it->second);
      it = fetches_.erase(it);
      expired = true;
    }
    ending.swap(finished_);
    std::erase_if(kept_, [&](const auto& entry) { return !still_there(entry.first); });
    std::erase_if(prefetched_, [&](const auto& entry) { return !still_there(entry.first); });
    for (auto& [root, tried] : prefetched_)
      if (tried.retry_at && now >= *tried.retry_at && !fetches_.count(root)) {
        tried.retry_at.reset();
        retries.emplace_back(root, tried.announcement);
      }
  }
  if (expired) changed_.notify_all();
  for (auto& fetch : ending) unsubscribe(*fetch);
  if (readiness_)
    for (const auto& [root, r] : not_ready) readiness_(root, r);
  for (const auto& [root, announcement] : retries) {
    log::debug([&] { return log::domain_prefix(domain_) + "asking " + root + " for its description again"; });
    DescribeResult answer;
    begin(root, announcement, answer);
  }
}

std::optional<DescriptionFetcher::Clock::time_point> DescriptionFetcher::next_deadline(Clock::time_point now) const {
  std::lock_guard lock(mutex_);
  std::optional<Clock::time_point> next;
  const auto sooner = [&](Clock::time_point t) { next = next ? std::min(*next, t) : t; };
  if (!fetches_.empty() || !finished_.empty()) sooner(now + kInFlightCheck);
  for (const auto& [topic_root, f] : fetches_) {
    sooner(std::max(now, f->deadline));
    if (!f->told_not_ready) sooner(std::max(now, f->ready_deadline));
  }
  for (const auto& [topic_root, tried] : prefetched_)
    if (tried.retry_at) sooner(std::max(now, *tried.retry_at));
  return next;
}

std::map<std::string, std::uint64_t> DescriptionFetcher::rejected() const {
  std::lock_guard lock(mutex_);
  return rejected_;
}

}  // namespace rsd::dds
