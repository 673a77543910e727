#pragma once

#include <ostream>

#include "mac_registration/core/mac_result.hpp"

namespace mac_registration {

// The verification's confidence, signals and alternatives (nothing when the result was not verified).
void printVerification(std::ostream& out, const MacResult& result);

// A human-readable summary of a result: status, warnings, verification, counters and time per stage.
void printResultSummary(std::ostream& out, const MacResult& result);

}  // namespace mac_registration
