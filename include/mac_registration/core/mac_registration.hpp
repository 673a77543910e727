#pragma once

#include <string>

#include "mac_registration/core/correspondence_set.hpp"
#include "mac_registration/core/mac_result.hpp"
#include "mac_registration/core/parameters.hpp"
#include "mac_registration/core/pose_witness.hpp"
#include "mac_registration/core/stop_flag.hpp"

namespace mac_registration {

// Runs MAC on putative correspondences: compatibility graph (first or second order), bounded maximal
// clique search streamed into node-guided selection, one SVD hypothesis per selected clique, evaluation on
// all correspondences, refinement. Never throws for bad input or parameters and never prints: every
// outcome is in the result (success, status, message, warnings, counters, time per stage). The same input
// and parameters give the same result whatever num_threads is. A raised `stop` ends the registration early
// with status kCancelled. A `witness` (e.g. the clouds the correspondences came from) adds its evidence to
// the verification of the transform found, before the one decision on it; its time counts in
// times.verification_ms.
MacResult registerCorrespondences(const CorrespondenceSet& correspondences, const MacParams& params,
                                  const StopFlag* stop = nullptr, const PoseWitness* witness = nullptr);

// The SIMD kernels this process runs, for logs: the instruction set and each kernel's variant, e.g.
// "avx2 (pair test avx2, common-neighbour count avx2, bit transpose portable, descriptor scan avx2)". The
// widest set the CPU has, narrowed by the environment variable MAC_REGISTRATION_KERNELS ("avx2" or
// "portable"); every set gives the same results.
std::string kernelsInUse();

}  // namespace mac_registration
