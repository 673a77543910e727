#pragma once

// Runs a command-line tool as a user does, for the tools' tests: its exit status and what it printed.
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace mac_registration {
namespace test {

struct CliRun {
  int status = -1;     // the exit status, -1 when the tool did not exit normally or could not start
  std::string output;  // stdout and stderr
};

inline CliRun runTool(const std::string& binary, const std::string& arguments) {
  CliRun r;
  FILE* pipe = ::popen((binary + " " + arguments + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer;
  for (std::size_t n; (n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0;)
    r.output.append(buffer.data(), n);
  const int raw = ::pclose(pipe);
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return r;
}

}  // namespace test
}  // namespace mac_registration
