#pragma once

#include <atomic>

namespace mac_registration {

// Raised by another thread (a shutdown, a nodelet unload) to end a registration early. The pipeline reads
// it between stages and inside its long loops and then returns a result with status kCancelled, so that a
// process stops within a second whatever it is registering. Owned by the caller; may be null.
using StopFlag = std::atomic<bool>;

inline bool stopRequested(const StopFlag* stop) {
  return stop != nullptr && stop->load(std::memory_order_relaxed);
}

}  // namespace mac_registration
