#pragma once

#include <ostream>

#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

// A human-readable summary of a result: status, warnings, counters and time per stage.
void printResultSummary(std::ostream& out, const MacResult& result);

}  // namespace mac_registration
