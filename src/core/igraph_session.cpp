#include "igraph_session.hpp"

#include <igraph.h>

namespace mac_registration {
namespace {

// Guarded by igraphMutex(); igraph calls the handlers only from inside a session.
std::string g_last_error;
std::chrono::steady_clock::time_point g_deadline;
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

igraph_error_t interruptAtDeadline(void*) {
  return std::chrono::steady_clock::now() > g_deadline ? IGRAPH_INTERRUPTED : IGRAPH_SUCCESS;
}

}  // namespace

IgraphSession::IgraphSession(std::chrono::steady_clock::time_point deadline) : lock_(igraphMutex()) {
  g_last_error.clear();
  g_deadline = deadline;
  g_previous_error_handler = igraph_set_error_handler(recordError);
  g_previous_warning_handler = igraph_set_warning_handler(ignoreWarning);
  g_previous_interruption_handler = igraph_set_interruption_handler(interruptAtDeadline);
}

IgraphSession::~IgraphSession() {
  igraph_set_error_handler(g_previous_error_handler);
  igraph_set_warning_handler(g_previous_warning_handler);
  igraph_set_interruption_handler(g_previous_interruption_handler);
}

std::string IgraphSession::lastError() const { return g_last_error; }

bool IgraphSession::deadlinePassed() const { return std::chrono::steady_clock::now() > g_deadline; }

}  // namespace mac_registration
