#include "kernel_table.hpp"

#include "mac_registration/core/mac_registration.hpp"

namespace mac_registration {
namespace kernels {
namespace {

constexpr KernelSet kPortable = KernelSet::kPortable;

constexpr KernelTable kPortableRow = {
    {pairTestPortable, kPortable},
    {commonCountPortable, kPortable},
    {commonCounts4Portable, kPortable},
    {scanTilesPortable, kPortable},
};

#if MAC_REGISTRATION_X86
constexpr KernelSet kAvx2 = KernelSet::kAvx2;

constexpr KernelTable kAvx2Row = {
    {pairTestAvx2, kAvx2},
    {commonCountAvx2, kAvx2},
    {commonCounts4Avx2, kAvx2},
    {scanTilesAvx2, kAvx2},
};

// AVX-512 pays only in the common-neighbour count (its vector popcount); the pair test and the descriptor
// scan are as fast with AVX2.
constexpr KernelTable kAvx512Row = {
    {pairTestAvx2, kAvx2},
    {commonCountAvx512, KernelSet::kAvx512},
    {commonCounts4Avx512, KernelSet::kAvx512},
    {scanTilesAvx2, kAvx2},
};
#endif

}  // namespace

const KernelTable& kernelTable(KernelSet set) {
#if MAC_REGISTRATION_X86
  if (set == KernelSet::kAvx512) return kAvx512Row;
  if (set == KernelSet::kAvx2) return kAvx2Row;
#else
  (void)set;
#endif
  return kPortableRow;
}

const KernelTable& activeKernels() { return kernelTable(activeKernelSet()); }

std::string describeKernels(KernelSet set) {
  const KernelTable& row = kernelTable(set);
  return std::string(kernelSetName(set)) + " (pair test " + kernelSetName(row.pair_test.written_for) +
         ", common-neighbour count " + kernelSetName(row.common_count.written_for) + ", descriptor scan " +
         kernelSetName(row.descriptor_scan.written_for) + ")";
}

}  // namespace kernels

std::string kernelsInUse() { return kernels::describeKernels(kernels::activeKernelSet()); }

}  // namespace mac_registration
