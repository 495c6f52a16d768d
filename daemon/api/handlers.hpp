// The API's request handlers and what they read: the table, the sources' status and
// the counters /metrics reports. The routes (routes.hpp) name these handlers; the
// server (api_server.cpp) wires them to its listeners.
#pragma once

#include "api/api_server.hpp"
#include "api/exchange.hpp"
#include "api/format.hpp"
#include "api/server_loop.hpp"

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace rsd::api {

inline constexpr const char* kJson = "application/json";

void send_json(ApiResponse& res, int status, const nlohmann::json& body);
void send_error(ApiResponse& res, int status, const std::string& message);

class Handlers {
 public:
  // `status` is everything the API shows besides the table; it must outlive these.
  Handlers(SharedTable& t, const StatusView& s, std::string v) : table(t), status(s), version(std::move(v)) {}

  void handle_devices(const ApiRequest& req, ApiResponse& res);
  void handle_device(const ApiRequest& req, ApiResponse& res);
  void handle_description(const ApiRequest& req, ApiResponse& res);
  void handle_clients(const ApiRequest& req, ApiResponse& res);
  void handle_domains(const ApiRequest& req, ApiResponse& res);
  void handle_participants(const ApiRequest& req, ApiResponse& res);
  void handle_health(const ApiRequest& req, ApiResponse& res);
  void handle_expected(const ApiRequest& req, ApiResponse& res);
  void handle_page(const ApiRequest& req, ApiResponse& res);
  void handle_spec(const ApiRequest& req, ApiResponse& res);
  void handle_metrics(const ApiRequest& req, ApiResponse& res);
  void handle_events(const ApiRequest& req, ApiResponse& res);  // events.cpp
  void handle_device_history(const ApiRequest& req, ApiResponse& res);  // history_handlers.cpp
  void handle_history(const ApiRequest& req, ApiResponse& res);         // history_handlers.cpp

  SharedTable& table;
  const StatusView& status;
  const std::string version;
  ApiOptions options;
  // The running loop, for /metrics; null while stopped (set and cleared by the
  // server with no request in flight).
  ServerLoop* loop = nullptr;
  // /healthz "http": where HTTP listens against what the configuration names
  // (set by the server's start with no request in flight).
  model::HttpHealth http_status;

  // Names these handlers in the threads' list caches (see device_list).
  const std::uint64_t instance = next_instance++;
  static inline std::atomic<std::uint64_t> next_instance{1};

  std::atomic<std::uint64_t> events_sent{0};
  std::atomic<std::size_t> streams_open{0};
  std::atomic<std::uint64_t> streams_rejected{0};
  // Answers by status (100-599), counted without a lock: every request touches it.
  std::array<std::atomic<std::uint64_t>, 600> requests_by_status{};

  // The /v1/devices body of the table's current generation for `filter` and
  // `fields` (`query`: the parameters as the cache's key), made once per generation
  // and thread. Also PlainList's, which serves the plain list without httplib.
  std::shared_ptr<const SharedBody> device_list(const DeviceFilter& filter, const DeviceFields& fields,
                                                const std::string& query, bool done, std::uint64_t& generation);

 private:
  std::vector<DomainStatus> domains() const;
  // The devices `name` names: the one with that id, else those with that serial
  // or topic-root.
  std::vector<EntryPtr> lookup(const std::string& name) const;
};

}  // namespace rsd::api
