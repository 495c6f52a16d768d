// One DDS domain's side of USB sharing: the reader of
// rs-discoveryd/shared-usb that every daemon has, feeding a ShareBook, and, with
// share-usb on, the writer announcing this host's USB cameras. A thin Cyclone
// shell, made and deleted with its DomainSession's participant, on the main thread.
#pragma once

#include "dds/share_book.hpp"

#include <dds/dds.h>

#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace rsd::dds {

struct ShareOptions {
  bool share = false;              // announce this host's cameras (share-usb)
  std::string host_name;           // what other hosts list them under ("": gethostname)
  ShareBookOptions book;           // its `domain` is set by the session
};

class ShareSession {
 public:
  using Clock = std::chrono::steady_clock;

  ShareSession(SharedTable& table, ShareOptions options);
  ~ShareSession();
  ShareSession(const ShareSession&) = delete;
  ShareSession& operator=(const ShareSession&) = delete;

  // On the participant just made (`own_guid` is its GUID): the topic, the reader,
  // and the writer when sharing. Returns "" or why it could not (the domain's
  // device-info side carries on without sharing).
  std::string start(dds_entity_t participant, const std::string& own_guid, Clock::time_point now);
  // Deletes the writer and the reader. `for_good` (not a rebuild): this host's
  // cameras are disposed first, so other hosts drop them at once.
  void stop(bool for_good);
  // This host's cameras now (sighting id -> the USB source's document) and the
  // addresses it is reached at: written, changed or disposed to match. Main thread.
  void publish(const std::map<std::string, nlohmann::json>& cameras, const std::vector<std::string>& addresses);
  Clock::duration tick(Clock::time_point now);
  void forget_devices(model::RemovalReason reason);
  void fill(DomainStatus& status) const;
  bool sharing() const { return writer_ > 0; }

 private:
  static void on_data_available(dds_entity_t reader, void* arg);
  void take_samples(dds_entity_t reader);
  // The participant GUID of a matched writer, cached: one lookup per writer. Takes
  // mutex_ (not held by the caller).
  std::string participant_of_writer(dds_entity_t reader, dds_instance_handle_t writer);
  bool write(const std::string& camera, const std::string& payload);
  void dispose(const std::string& camera);

  ShareOptions options_;
  dds_entity_t topic_ = 0, reader_ = 0, writer_ = 0;  // main thread
  std::map<std::string, std::string> published_;      // camera id -> payload written (main thread)

  mutable std::mutex mutex_;  // the book and the cache; listener thread and main loop
  ShareBook book_;
  std::map<dds_instance_handle_t, std::string> writer_participants_;
};

}  // namespace rsd::dds
