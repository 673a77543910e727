#pragma once

#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace mac_registration {

// Raised by another thread (a shutdown, a nodelet unload) to end a registration early. The pipeline reads
// it between stages and inside its long loops and then returns a result with status kCancelled, so that a
// process stops within a second whatever it is registering. Owned by the caller; may be null.
using StopFlag = std::atomic<bool>;

inline bool stopRequested(const StopFlag* stop) {
  return stop != nullptr && stop->load(std::memory_order_relaxed);
}

// What a stage that returns a value (the front end's: describeCloud, voxelDownsample, estimateNormals,
// computeFpfh, matchFeatures...) throws when the stop flag ended it early; what it had computed is
// dropped. registerClouds and registerCloudToDescribed turn it into a result with status kCancelled.
class Cancelled : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws Cancelled ("cancelled " + `where`) when the flag is raised: between the stages of a front end.
inline void throwIfStopped(const StopFlag* stop, const char* where) {
  if (stopRequested(stop)) throw Cancelled(std::string("cancelled ") + where);
}

// Inside a parallel loop over many points, which cannot break (an OpenMP loop must run every iteration
// and no exception may leave it): one per thread, it reads the flag every kStride iterations and, once it
// was raised, says so at every iteration after, which then skips its work. The stage throws after the
// loop. A flag read costs little, but every iteration of a loop of a few nanoseconds would still be a
// load and a branch in the way of the compiler's vectorization.
class StopCheck {
 public:
  static constexpr std::uint32_t kStride = 4096;

  explicit StopCheck(const StopFlag* stop) : stop_(stop) {}
  bool stopped() {
    if (stopped_) return true;
    if (++count_ < kStride) return false;
    count_ = 0;
    stopped_ = stopRequested(stop_);
    return stopped_;
  }

 private:
  const StopFlag* stop_;
  std::uint32_t count_ = kStride - 1;  // the first iteration reads the flag
  bool stopped_ = false;
};

}  // namespace mac_registration
