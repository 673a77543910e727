#pragma once

// The hand-written SIMD kernels are x86's; on other CPUs (ARM robot computers) only the portable variants
// are built, and the compiler's clones for AVX2 and POPCNT are x86's too.
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
namespace kernels {

// The instruction sets a row of the kernel table (kernel_table.hpp) is written for, narrowest first.
// kAvx2 needs AVX2 and FMA; kAvx512 needs AVX-512F and VPOPCNTDQ too (the only kernel that pays with
// AVX-512 is the common-neighbour count, and it is VPOPCNTDQ that makes it pay).
enum class KernelSet { kPortable, kAvx2, kAvx512 };

constexpr KernelSet kAllKernelSets[] = {KernelSet::kPortable, KernelSet::kAvx2, KernelSet::kAvx512};

const char* kernelSetName(KernelSet set);  // "portable", "avx2", "avx512"

// Whether this CPU has the instructions of `set`'s kernels (kPortable: always).
bool cpuRuns(KernelSet set);

// The set the library runs: the widest this CPU runs, narrowed by the environment variable
// MAC_REGISTRATION_KERNELS ("avx2" or "portable": at most that set; unset, empty or any other value: no
// narrowing), so that a CPU with AVX-512 can run and time what a CPU without it runs. Read once.
KernelSet activeKernelSet();

}  // namespace kernels
}  // namespace mac_registration
