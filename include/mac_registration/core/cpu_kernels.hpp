#pragma once

namespace mac_registration {

// Whether the AVX-512 kernels may run: the CPU has AVX-512F (for avx512PopcountKernels, VPOPCNTDQ too) and
// MAC_REGISTRATION_PORTABLE_KERNELS is unset, empty or "0". Every AVX-512 kernel has a portable twin that
// gives the same results bit for bit, the one a CPU without AVX-512 runs; set, the variable makes a CPU
// with it run the twins too, so that the tests check them and their speed can be measured. Read once.
bool avx512Kernels();
bool avx512PopcountKernels();

}  // namespace mac_registration
