#include "cpu_kernels.hpp"

#include <cstdlib>
#include <cstring>

namespace mac_registration {
#if MAC_REGISTRATION_X86
namespace {

bool narrowedTo(const char* set) {
  const char* value = std::getenv("MAC_REGISTRATION_KERNELS");
  return value != nullptr && std::strcmp(value, set) == 0;
}

}  // namespace

bool avx2Kernels() {
  static const bool enabled =
      !narrowedTo("portable") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return enabled;
}

bool avx512Kernels() {
  static const bool enabled = avx2Kernels() && !narrowedTo("avx2") && __builtin_cpu_supports("avx512f");
  return enabled;
}

bool avx512PopcountKernels() {
  static const bool enabled = avx512Kernels() && __builtin_cpu_supports("avx512vpopcntdq");
  return enabled;
}

#else

bool avx2Kernels() { return false; }
bool avx512Kernels() { return false; }
bool avx512PopcountKernels() { return false; }

#endif

}  // namespace mac_registration
