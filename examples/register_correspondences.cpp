// The C++ API in one page: putative correspondences in, T_target_source out, with a preset.
//   register_correspondences CORRESPONDENCES.txt [PRESET.yaml]
// e.g. on the shipped real FPFH set:
//   register_correspondences test/data/redkitchen_24_59/correspondences.txt config/indoor_rgbd.yaml
#include <mac_registration/config/preset_file.hpp>
#include <mac_registration/core/mac_registration.hpp>
#include <mac_registration/core/text_io.hpp>

#include <exception>
#include <iostream>

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::cerr << "usage: register_correspondences CORRESPONDENCES.txt [PRESET.yaml]\n";
    return 2;
  }
  mac_registration::RegistrationConfig config;  // the defaults: the indoor preset's values
  mac_registration::CorrespondenceSet correspondences;
  try {
    if (argc == 3) mac_registration::loadPresetFile(config, argv[2]);
    // One "xs ys zs xt yt zt" a line [m]; or fill correspondences.source_points / target_points (3 x N).
    correspondences = mac_registration::readCorrespondencesFile(argv[1]);
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 2;
  }

  // Never throws: every outcome, failures included, is in the result.
  const mac_registration::MacResult result =
      mac_registration::registerCorrespondences(correspondences, config.mac);
  if (!result.success) {
    std::cerr << "not registered (" << mac_registration::toString(result.status) << "): " << result.message
              << "\n";
    return 1;
  }
  std::cout << "T_target_source (maps source points into the target frame):\n"
            << mac_registration::formatTransform(result.T_target_source) << result.counters.inliers
            << " inliers of " << result.counters.correspondences << " correspondences in "
            << result.times.total_ms << " ms\n";
  return 0;
}
