#pragma once

#include <chrono>
#include <mutex>
#include <string>

namespace mac_registration {

// Exclusive use of igraph for one scope. Debian's igraph is built without thread-local state, and its
// default error handler aborts the process: this holds a process-wide lock, installs handlers that record
// the error instead of aborting, and lets long searches be interrupted at a deadline.
class IgraphSession {
 public:
  explicit IgraphSession(std::chrono::steady_clock::time_point deadline);
  ~IgraphSession();
  IgraphSession(const IgraphSession&) = delete;
  IgraphSession& operator=(const IgraphSession&) = delete;

  // The message of the last igraph error in this session, empty if none.
  std::string lastError() const;
  bool deadlinePassed() const;

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace mac_registration
