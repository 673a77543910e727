#include "kernel_sets.hpp"

#include <cstdlib>
#include <cstring>

namespace mac_registration {
namespace kernels {

const char* kernelSetName(KernelSet set) {
  switch (set) {
    case KernelSet::kAvx2:
      return "avx2";
    case KernelSet::kAvx512:
      return "avx512";
    case KernelSet::kPortable:
      break;
  }
  return "portable";
}

bool cpuRuns(KernelSet set) {
#if MAC_REGISTRATION_X86
  switch (set) {
    case KernelSet::kPortable:
      return true;
    case KernelSet::kAvx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
             __builtin_cpu_supports("popcnt");
    case KernelSet::kAvx512:
      return cpuRuns(KernelSet::kAvx2) && __builtin_cpu_supports("avx512f") &&
             __builtin_cpu_supports("avx512vpopcntdq");
  }
  return false;
#else
  return set == KernelSet::kPortable;
#endif
}

namespace {

KernelSet widestAllowed() {
  const char* value = std::getenv("MAC_REGISTRATION_KERNELS");
  if (value != nullptr && std::strcmp(value, "portable") == 0) return KernelSet::kPortable;
  if (value != nullptr && std::strcmp(value, "avx2") == 0) return KernelSet::kAvx2;
  return KernelSet::kAvx512;
}

}  // namespace

KernelSet activeKernelSet() {
  static const KernelSet active = [] {
    KernelSet chosen = KernelSet::kPortable;
    for (const KernelSet set : kAllKernelSets) {
      if (set <= widestAllowed() && cpuRuns(set)) chosen = set;
    }
    return chosen;
  }();
  return active;
}

}  // namespace kernels
}  // namespace mac_registration
