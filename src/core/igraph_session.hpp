#pragma once

#include <chrono>
#include <mutex>
#include <string>

#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

// Exclusive use of igraph for one scope. Debian's igraph is built without thread-local state, and its
// default error handler aborts the process: this holds a process-wide lock, installs handlers that record
// the error instead of aborting, and lets long searches be interrupted at a deadline or by a stop flag.
//
// igraph keeps the temporaries of the functions running in a process-wide cleanup ("finally") stack. An
// interrupted function returns without popping its entries, and its callers free them only if they see an
// error, after the frames that owned them are gone. So the interruption handler frees them itself, while
// those frames are still alive; and a session never ends with entries left for the next caller to free.
class IgraphSession {
 public:
  IgraphSession(std::chrono::steady_clock::time_point deadline, const StopFlag* stop);
  ~IgraphSession();
  IgraphSession(const IgraphSession&) = delete;
  IgraphSession& operator=(const IgraphSession&) = delete;

  // The message of the last igraph error in this session, empty if none.
  std::string lastError() const;
  // Entries still on igraph's cleanup stack, which belong to no live frame once igraph has returned.
  // Drops them without calling their destructors (a leak is recoverable, freeing dead frames is not) and
  // returns how many there were: 0 unless igraph broke its own convention.
  int dropStaleCleanups();

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace mac_registration
