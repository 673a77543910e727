#include "igraph_session.hpp"

#include <igraph.h>

#include "mac_registration/core/clique_search.hpp"

namespace mac_registration {
namespace {

// Guarded by igraphMutex(); igraph calls the handlers only from inside a session.
std::string g_last_error;
std::chrono::steady_clock::time_point g_deadline;
const StopFlag* g_stop = nullptr;
igraph_error_handler_t* g_previous_error_handler = nullptr;
igraph_warning_handler_t* g_previous_warning_handler = nullptr;
igraph_interruption_handler_t* g_previous_interruption_handler = nullptr;

std::mutex& igraphMutex() {
  static std::mutex mutex;
  return mutex;
}

void recordError(const char* reason, const char* file, int line, igraph_error_t code) {
  g_last_error =
      std::string(igraph_strerror(code)) + ": " + reason + " (" + file + ":" + std::to_string(line) + ")";
  // igraph leaves cleaning its stack of half-built objects to the handler.
  IGRAPH_FINALLY_FREE();
}

void ignoreWarning(const char*, const char*, int) {}

igraph_error_t interruptAtDeadlineOrStop(void*) {
  if (!stopRequested(g_stop) && std::chrono::steady_clock::now() <= g_deadline) return IGRAPH_SUCCESS;
  // The functions being interrupted return without popping their temporaries: free them now, while the
  // frames that own them still exist (igraph's convention, as its R and Python interfaces do).
  IGRAPH_FINALLY_FREE();
  return IGRAPH_INTERRUPTED;
}

}  // namespace

IgraphSession::IgraphSession(std::chrono::steady_clock::time_point deadline, const StopFlag* stop)
    : lock_(igraphMutex()) {
  g_last_error.clear();
  g_deadline = deadline;
  g_stop = stop;
  g_previous_error_handler = igraph_set_error_handler(recordError);
  g_previous_warning_handler = igraph_set_warning_handler(ignoreWarning);
  g_previous_interruption_handler = igraph_set_interruption_handler(interruptAtDeadlineOrStop);
}

IgraphSession::~IgraphSession() {
  dropStaleCleanups();
  igraph_set_error_handler(g_previous_error_handler);
  igraph_set_warning_handler(g_previous_warning_handler);
  igraph_set_interruption_handler(g_previous_interruption_handler);
  g_stop = nullptr;
}

std::string IgraphSession::lastError() const { return g_last_error; }

int IgraphSession::dropStaleCleanups() {
  const int stale = IGRAPH_FINALLY_STACK_SIZE();
  if (stale > 0) IGRAPH_FINALLY_CLEAN(stale);
  return stale;
}

int igraphCleanupStackSize() {
  const std::lock_guard<std::mutex> lock(igraphMutex());
  return IGRAPH_FINALLY_STACK_SIZE();
}

}  // namespace mac_registration
