// Internal to the core: the clock of the clique search's time budget.
#pragma once

#include <time.h>

#include <chrono>
#include <cstdint>

namespace mac_registration {

// The CPU time the calling thread has run. It stands still while the thread waits (for igraph's
// process-wide lock, for the selection's worker) or is descheduled by other work on the machine, so a
// budget counted on it ends at the same point of the work whatever runs beside it: two registrations of
// the same input give the same result under load as alone. On an idle machine it runs with the wall
// clock. Its time points belong to one thread: never compare those read on different threads.
struct ThreadCpuClock {
  using duration = std::chrono::nanoseconds;
  using rep = duration::rep;
  using period = duration::period;
  using time_point = std::chrono::time_point<ThreadCpuClock>;
  static constexpr bool is_steady = true;

  // A system call (~1 us on a loaded VM): read it every so many steps of a loop, not every step.
  static time_point now() noexcept {
    timespec now{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
    return time_point(duration(std::int64_t(now.tv_sec) * 1000000000 + now.tv_nsec));
  }
};

}  // namespace mac_registration
