#include "igraph_session.hpp"

#include <igraph.h>

#include "clique_search.hpp"

namespace mac_registration {
namespace {

// Guarded by igraphMutex(); igraph calls the handlers only from inside a session, on its thread.
std::string g_last_error;
ThreadCpuClock::time_point g_deadline = ThreadCpuClock::time_point::max();
const StopFlag* g_stop = nullptr;
unsigned g_interruption_checks = 0;
igraph_error_handler_t* g_previous_error_handler = nullptr;
igraph_warning_handler_t* g_previous_warning_handler = nullptr;
igraph_interruption_handler_t* g_previous_interruption_handler = nullptr;

// How often a session waiting for the lock reads its stop flag: well inside the second a shutdown has.
constexpr std::chrono::milliseconds kStopPoll(20);

std::timed_mutex& igraphMutex() {
  static std::timed_mutex mutex;
  return mutex;
}

void recordError(const char* reason, const char* file, int line, igraph_error_t code) {
  g_last_error =
      std::string(igraph_strerror(code)) + ": " + reason + " (" + file + ":" + std::to_string(line) + ")";
  // igraph leaves cleaning its stack of half-built objects to the handler.
  IGRAPH_FINALLY_FREE();
}

void ignoreWarning(const char*, const char*, int) {}

// igraph calls this a few times per vertex it works through. The CPU clock is a system call (up to a
// microsecond on a loaded VM, a tenth of a search's time if read at every call): it is read at every 8th,
// a few vertices apart, the first call included.
igraph_error_t interruptAtDeadlineOrStop(void*) {
  const bool late = (++g_interruption_checks & 7u) == 0 && ThreadCpuClock::now() > g_deadline;
  if (!late && !stopRequested(g_stop)) return IGRAPH_SUCCESS;
  // The functions being interrupted return without popping their temporaries: free them now, while the
  // frames that own them still exist (igraph's convention, as its R and Python interfaces do).
  IGRAPH_FINALLY_FREE();
  return IGRAPH_INTERRUPTED;
}

}  // namespace

IgraphSession::IgraphSession(const StopFlag* stop) : lock_(igraphMutex(), std::defer_lock) {
  const auto start = std::chrono::steady_clock::now();
  while (!lock_.try_lock_for(kStopPoll)) {
    if (stopRequested(stop)) break;
  }
  waited_ = std::chrono::steady_clock::now() - start;
  if (!held()) return;
  g_last_error.clear();
  g_deadline = ThreadCpuClock::time_point::max();
  g_interruption_checks = 7;
  g_stop = stop;
  g_previous_error_handler = igraph_set_error_handler(recordError);
  g_previous_warning_handler = igraph_set_warning_handler(ignoreWarning);
  g_previous_interruption_handler = igraph_set_interruption_handler(interruptAtDeadlineOrStop);
}

IgraphSession::~IgraphSession() {
  if (!held()) return;
  dropStaleCleanups();
  igraph_set_error_handler(g_previous_error_handler);
  igraph_set_warning_handler(g_previous_warning_handler);
  igraph_set_interruption_handler(g_previous_interruption_handler);
  g_stop = nullptr;
}

void IgraphSession::interruptAt(ThreadCpuClock::time_point deadline) { g_deadline = deadline; }

std::string IgraphSession::lastError() const { return g_last_error; }

int IgraphSession::dropStaleCleanups() {
  const int stale = IGRAPH_FINALLY_STACK_SIZE();
  if (stale > 0) IGRAPH_FINALLY_CLEAN(stale);
  return stale;
}

int igraphCleanupStackSize() {
  const std::lock_guard<std::timed_mutex> lock(igraphMutex());
  return IGRAPH_FINALLY_STACK_SIZE();
}

}  // namespace mac_registration
