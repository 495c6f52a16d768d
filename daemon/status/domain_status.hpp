// What a DDS domain reports about itself, for /v1/domains, /healthz, /metrics and
// STATUS=. The DDS source fills it, the service and the API read it, and neither
// side includes the other's headers. The type is the API's own document
// (proto/model/rsd_model/status.hpp), so the daemon and its clients share it.
#pragma once

#include "rsd_model/status.hpp"

namespace rsd {

using model::DomainState;
using model::DomainStatus;
using model::parse_domain_state;

}  // namespace rsd
