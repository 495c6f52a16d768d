// Which of the expected cameras (Config::expect) the table lists now: the one
// computation behind /v1/expected, /healthz, /metrics and STATUS=, so that they
// never disagree. A camera is listed when an entry is named by its serial or
// topic-root (model::Device::named_by, the API's lookup rule).
#pragma once

#include "table/shared_table.hpp"

#include "rsd_model/expected.hpp"

#include <vector>

namespace rsd {

// Pure: over the entries of a snapshot.
model::ExpectedReport expected_report(const std::vector<model::ExpectedCamera>& expected,
                                      const std::vector<EntryPtr>& devices, bool complete);

// Over the table now; what the table knows of a missing camera's last sighting
// (its last-seen, why it went) fills the missing ones.
model::ExpectedReport expected_report(const std::vector<model::ExpectedCamera>& expected, const SharedTable& table,
                                      bool complete);

}  // namespace rsd
