#pragma once

// The transposition of 64 x 64 bit blocks with which the counted second-order pass gives every bit row
// its lower half (the mirror of the upper rows it built).

#include <cstdint>

#include "kernel_sets.hpp"

namespace mac_registration {
namespace kernels {

// Transposes a 64 x 64 bit block in place, bit c of a[r] being entry (r, c).
using TransposeBits = void (*)(std::uint64_t a[64]);

void transposeBitsPortable(std::uint64_t a[64]);
#if MAC_REGISTRATION_X86
void transposeBitsAvx512(std::uint64_t a[64]);
#endif

}  // namespace kernels
}  // namespace mac_registration
