#pragma once

#include <chrono>
#include <mutex>
#include <string>

#include "mac_registration/core/stop_flag.hpp"
#include "thread_cpu_clock.hpp"

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
  // Waits for the lock while another thread's session holds it, reading `stop` as it waits: a registration
  // queued behind another's search must not hold up a shutdown. When `stop` is raised first the session
  // is not held (held() is false) and igraph must not be called.
  explicit IgraphSession(const StopFlag* stop);
  ~IgraphSession();
  IgraphSession(const IgraphSession&) = delete;
  IgraphSession& operator=(const IgraphSession&) = delete;

  bool held() const { return lock_.owns_lock(); }
  // How long the constructor waited for another session to end.
  std::chrono::steady_clock::duration waited() const { return waited_; }
  // igraph is interrupted once this thread's CPU time passes `deadline` (none until this is called).
  void interruptAt(ThreadCpuClock::time_point deadline);

  // The message of the last igraph error in this session, empty if none.
  std::string lastError() const;
  // Entries still on igraph's cleanup stack, which belong to no live frame once igraph has returned.
  // Drops them without calling their destructors (a leak is recoverable, freeing dead frames is not) and
  // returns how many there were: 0 unless igraph broke its own convention.
  int dropStaleCleanups();

 private:
  std::unique_lock<std::timed_mutex> lock_;
  std::chrono::steady_clock::duration waited_{};
};

}  // namespace mac_registration
