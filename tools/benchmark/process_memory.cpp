#include "process_memory.hpp"

#include <sys/resource.h>

#include <fstream>
#include <sstream>
#include <string>

namespace mac_registration {

void resetPeakMemory() {
  // Without the file (not Linux, or /proc not mounted) the peak stays the whole run's: a larger number,
  // never a smaller one.
  std::ofstream clear_refs("/proc/self/clear_refs");
  clear_refs << "5";
}

double peakMemoryMb() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) != 0) continue;
    std::istringstream fields(line.substr(6));
    double kib = 0.0;
    if (fields >> kib) return kib / 1024.0;
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

}  // namespace mac_registration
