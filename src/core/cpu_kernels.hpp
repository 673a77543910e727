#pragma once

// The hand-written kernels are x86's (AVX2, AVX-512); on other CPUs (ARM robot computers) only the portable
// twins are built, and the compiler's clones for AVX2 and POPCNT are x86's too.
#if defined(__x86_64__) || defined(__i386__)
#define MAC_REGISTRATION_X86 1
#define MAC_REGISTRATION_CLONES_AVX2 __attribute__((target_clones("avx2", "default")))
#define MAC_REGISTRATION_CLONES_POPCNT __attribute__((target_clones("popcnt", "default")))
#else
#define MAC_REGISTRATION_X86 0
#define MAC_REGISTRATION_CLONES_AVX2
#define MAC_REGISTRATION_CLONES_POPCNT
#endif

namespace mac_registration {

// Which of the hand-written SIMD kernels may run: the widest set the CPU has, narrowed by the environment
// variable MAC_REGISTRATION_KERNELS ("avx2": no AVX-512 kernel; "portable": none, only the compiler's
// code; unset, empty or any other value: no narrowing). Every kernel has a portable twin that gives the
// same results bit for bit, and the pair test, the common-neighbour count and the descriptor scan an AVX2
// twin too: the variable makes a CPU with AVX-512 run what a CPU without it runs, so that the tests check
// the twins and their speed can be measured. Read once. All false on other CPUs than x86.
bool avx512Kernels();          // AVX-512F
bool avx512PopcountKernels();  // AVX-512F and VPOPCNTDQ
bool avx2Kernels();            // AVX2 and FMA (whatever avx512Kernels() says)

}  // namespace mac_registration
