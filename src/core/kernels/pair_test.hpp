#pragma once

// The pair test of the first-order graph: for one point i of a structure-of-arrays point set, the points
// j > i whose pair with i is compatible (d^2 <= max_d2, d = |s_i - s_j| - |t_i - t_j|), compacted.

#include <cstddef>

#include "kernel_sets.hpp"

namespace mac_registration {
namespace kernels {

// Entries past a row's end that a variant may write: candidates and candidate_d2 need room for
// n - i - 1 + kPairTestSlack, and what lies past the found ones is scratch.
constexpr std::size_t kPairTestSlack = 16;

// The pairs (i, j > i) of the n points that pass d^2 <= max_d2: candidates[c] = j and candidate_d2[c] = d^2
// for the found ones, ascending in j; returns how many. `scratch` holds n floats. Every variant gives the
// same pairs and d^2 bit for bit (the same IEEE operations in the same order, no contraction).
using PairTest = int (*)(const float* sx, const float* sy, const float* sz, const float* tx, const float* ty,
                         const float* tz, int i, int n, float max_d2, float* scratch, int* candidates,
                         float* candidate_d2);

int pairTestPortable(const float* sx, const float* sy, const float* sz, const float* tx, const float* ty,
                     const float* tz, int i, int n, float max_d2, float* scratch, int* candidates,
                     float* candidate_d2);
#if MAC_REGISTRATION_X86
int pairTestAvx2(const float* sx, const float* sy, const float* sz, const float* tx, const float* ty,
                 const float* tz, int i, int n, float max_d2, float* scratch, int* candidates,
                 float* candidate_d2);
int pairTestAvx512(const float* sx, const float* sy, const float* sz, const float* tx, const float* ty,
                   const float* tz, int i, int n, float max_d2, float* scratch, int* candidates,
                   float* candidate_d2);
#endif

}  // namespace kernels
}  // namespace mac_registration
