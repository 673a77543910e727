#pragma once

// The common-neighbour count of the second-order graph: the number of bits that two bit rows share (the
// neighbour sets of an edge's two ends, rows as the counted second-order pass lays them out: whole 512-bit
// blocks, words a multiple of 8, starting on a cache line).

#include <cstddef>
#include <cstdint>

#include "kernel_sets.hpp"

namespace mac_registration {
namespace kernels {

// popcount(a & b) over `words` 64-bit words.
using CommonCount = std::int64_t (*)(const std::uint64_t* a, const std::uint64_t* b, std::size_t words);
// The same of row a against four rows at once: out[k] = popcount(a & b[k]).
using CommonCounts4 = void (*)(const std::uint64_t* a, const std::uint64_t* const b[4], std::size_t words,
                               std::int64_t out[4]);

std::int64_t commonCountPortable(const std::uint64_t* a, const std::uint64_t* b, std::size_t words);
void commonCounts4Portable(const std::uint64_t* a, const std::uint64_t* const b[4], std::size_t words,
                           std::int64_t out[4]);
#if MAC_REGISTRATION_X86
std::int64_t commonCountAvx2(const std::uint64_t* a, const std::uint64_t* b, std::size_t words);
void commonCounts4Avx2(const std::uint64_t* a, const std::uint64_t* const b[4], std::size_t words,
                       std::int64_t out[4]);
std::int64_t commonCountAvx512(const std::uint64_t* a, const std::uint64_t* b, std::size_t words);
void commonCounts4Avx512(const std::uint64_t* a, const std::uint64_t* const b[4], std::size_t words,
                         std::int64_t out[4]);
#endif

}  // namespace kernels
}  // namespace mac_registration
