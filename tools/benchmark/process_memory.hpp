#pragma once

namespace mac_registration {

// The peak resident memory of this process since the last reset, so that one process can report the
// peak of each benchmark pair in turn. The reset sets the peak to the current resident set (Linux's
// /proc/self/clear_refs "5"), so the peak includes what the process holds already (binary, libraries).
void resetPeakMemory();

// [MiB] VmHWM of /proc/self/status; getrusage's ru_maxrss (the peak since the start) when that is not
// readable.
double peakMemoryMb();

}  // namespace mac_registration
