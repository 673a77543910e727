#include "kernel_table.hpp"

#include "mac_registration/core/mac_registration.hpp"

namespace mac_registration {
namespace kernels {
namespace {

constexpr KernelSet kPortable = KernelSet::kPortable;

// clang-format off
// One variant a line, in the order of KernelTable's members.
constexpr KernelTable kPortableRow = {
    {pairTestPortable, kPortable},
    {commonCountPortable, kPortable},
    {commonCounts4Portable, kPortable},
    {transposeBitsPortable, kPortable},
    {scanTilesPortable, kPortable},
};

#if MAC_REGISTRATION_X86
constexpr KernelSet kAvx2 = KernelSet::kAvx2;

constexpr KernelTable kAvx2Row = {
    {pairTestAvx2, kAvx2},
    {commonCountAvx2, kAvx2},
    {commonCounts4Avx2, kAvx2},
    {transposeBitsPortable, kPortable},  // no AVX2 variant: 0.9 ms of one thread at 5000 active nodes
    {scanTilesAvx2, kAvx2},
};

constexpr KernelSet kAvx512 = KernelSet::kAvx512;

constexpr KernelTable kAvx512Row = {
    {pairTestAvx512, kAvx512},
    {commonCountAvx512, kAvx512},
    {commonCounts4Avx512, kAvx512},
    {transposeBitsAvx512, kAvx512},
    {scanTilesAvx512, kAvx512},
};
#endif
// clang-format on

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
         ", common-neighbour count " + kernelSetName(row.common_count.written_for) + ", bit transpose " +
         kernelSetName(row.transpose_bits.written_for) + ", descriptor scan " +
         kernelSetName(row.descriptor_scan.written_for) + ")";
}

}  // namespace kernels

std::string kernelsInUse() { return kernels::describeKernels(kernels::activeKernelSet()); }

}  // namespace mac_registration
