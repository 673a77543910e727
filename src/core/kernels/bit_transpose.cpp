#include "bit_transpose.hpp"

#include <initializer_list>

#if MAC_REGISTRATION_X86
#include <immintrin.h>
#endif

namespace mac_registration {
namespace kernels {

// Transposes a 64 x 64 bit block in place, bit c of a[r] being entry (r, c): swaps its off-diagonal
// halves, then the quarters' within each half, down to single bits.
void transposeBitsPortable(std::uint64_t a[64]) {
  std::uint64_t mask = 0x00000000FFFFFFFFull;
  for (int j = 32; j != 0; j >>= 1, mask ^= mask << j) {
    for (int k = 0; k < 64; k = ((k | j) + 1) & ~j) {
      const std::uint64_t t = ((a[k] >> j) ^ a[k | j]) & mask;
      a[k | j] ^= t;
      a[k] ^= t << j;
    }
  }
}

#if MAC_REGISTRATION_X86
namespace {

// GCC 12 warns of the undefined vectors its AVX-512 shift and blend intrinsics start from (a false
// positive, GCC bug 105593).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// A stage of that swap between rows k (in x) and k + J, in a register J / 8 further on.
template <int J>
__attribute__((target("avx512f"), always_inline)) inline void swapAcross(__m512i& x, __m512i& y,
                                                                         std::uint64_t mask) {
  const __m512i t = _mm512_and_si512(_mm512_xor_si512(_mm512_srli_epi64(x, J), y), _mm512_set1_epi64(mask));
  y = _mm512_xor_si512(y, t);
  x = _mm512_xor_si512(x, _mm512_slli_epi64(t, J));
}

// A stage between the lanes k and k ^ J of one register (`partner` permutes them; `upper` marks the k + J).
template <int J>
__attribute__((target("avx512f"), always_inline)) inline void swapWithin(__m512i& x, __m512i partner,
                                                                         __mmask8 upper, std::uint64_t mask) {
  const __m512i t =
      _mm512_and_si512(_mm512_xor_si512(_mm512_srli_epi64(x, J), _mm512_permutexvar_epi64(partner, x)),
                       _mm512_set1_epi64(mask));
  x = _mm512_xor_si512(
      x, _mm512_mask_blend_epi64(upper, _mm512_slli_epi64(t, J), _mm512_permutexvar_epi64(partner, t)));
}

}  // namespace

// The same swaps on eight rows a register, all six stages in registers: a tenth of the portable time.
__attribute__((target("avx512f"))) void transposeBitsAvx512(std::uint64_t a[64]) {
  __m512i r[8];
  for (int m = 0; m < 8; ++m) r[m] = _mm512_loadu_si512(a + 8 * m);
  for (int m = 0; m < 4; ++m) swapAcross<32>(r[m], r[m + 4], 0x00000000FFFFFFFFull);
  for (const int m : {0, 1, 4, 5}) swapAcross<16>(r[m], r[m + 2], 0x0000FFFF0000FFFFull);
  for (const int m : {0, 2, 4, 6}) swapAcross<8>(r[m], r[m + 1], 0x00FF00FF00FF00FFull);
  const __m512i partner4 = _mm512_setr_epi64(4, 5, 6, 7, 0, 1, 2, 3);
  const __m512i partner2 = _mm512_setr_epi64(2, 3, 0, 1, 6, 7, 4, 5);
  const __m512i partner1 = _mm512_setr_epi64(1, 0, 3, 2, 5, 4, 7, 6);
  for (int m = 0; m < 8; ++m) {
    swapWithin<4>(r[m], partner4, 0xF0, 0x0F0F0F0F0F0F0F0Full);
    swapWithin<2>(r[m], partner2, 0xCC, 0x3333333333333333ull);
    swapWithin<1>(r[m], partner1, 0xAA, 0x5555555555555555ull);
  }
  for (int m = 0; m < 8; ++m) _mm512_storeu_si512(a + 8 * m, r[m]);
}

#pragma GCC diagnostic pop

#endif  // MAC_REGISTRATION_X86

}  // namespace kernels
}  // namespace mac_registration
