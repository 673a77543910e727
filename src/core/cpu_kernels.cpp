#include "mac_registration/core/cpu_kernels.hpp"

#include <cstdlib>
#include <cstring>

namespace mac_registration {
namespace {

bool portableKernelsAsked() {
  const char* value = std::getenv("MAC_REGISTRATION_PORTABLE_KERNELS");
  return value != nullptr && value[0] != '\0' && std::strcmp(value, "0") != 0;
}

}  // namespace

bool avx512Kernels() {
  static const bool enabled = !portableKernelsAsked() && __builtin_cpu_supports("avx512f");
  return enabled;
}

bool avx512PopcountKernels() {
  static const bool enabled = avx512Kernels() && __builtin_cpu_supports("avx512vpopcntdq");
  return enabled;
}

}  // namespace mac_registration
