#pragma once

// The one table of the library's hand-written kernels: for each instruction set (kernel_sets.hpp), the
// variant of every kernel that runs with it. A kernel has a portable variant (plain C++; on x86 with the
// compiler's AVX2 clone) and SIMD variants where they pay (doc/decisions/kernel-layer.md). Every
// variant of a kernel gives the same results bit for bit; test/core/test_kernels.cpp runs each against the
// portable one.

#include <string>

#include "bit_transpose.hpp"
#include "common_neighbours.hpp"
#include "descriptor_scan.hpp"
#include "kernel_sets.hpp"
#include "pair_test.hpp"

namespace mac_registration {
namespace kernels {

template <typename Function>
struct Variant {
  Function run;
  KernelSet written_for;  // the narrowest set whose instructions `run` uses
};

struct KernelTable {
  Variant<PairTest> pair_test;            // the first-order graph's O(N^2) loop
  Variant<CommonCount> common_count;      // the second-order weights of dense graphs
  Variant<CommonCounts4> common_counts4;  // the same, four rows at once
  Variant<TransposeBits> transpose_bits;  // the mirror of the second-order pass's bit rows
  Variant<ScanTiles> descriptor_scan;     // the front end's exact FPFH matching
};

// The row of `set`. Its SIMD variants run only where cpuRuns(set).
const KernelTable& kernelTable(KernelSet set);

// The row of activeKernelSet(): what the library runs.
const KernelTable& activeKernels();

// "avx2 (pair test avx2, common-neighbour count avx2, bit transpose portable, descriptor scan avx2)": the
// set and each kernel's variant, for logs.
std::string describeKernels(KernelSet set);

}  // namespace kernels
}  // namespace mac_registration
