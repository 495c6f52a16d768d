// The DDS side's status values live in status/ (shared with the frontends, which
// include no DDS header); this name stays for the DDS code that includes it.
#pragma once

#include "status/device_description.hpp"
#include "status/domain_status.hpp"
