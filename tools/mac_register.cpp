// mac_register: registers one correspondence set and prints T_target_source.
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "cli_config.hpp"
#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/text_io.hpp"
#include "result_report.hpp"

namespace {

constexpr const char* kUsage =
    "usage: mac_register --correspondences FILE [--config FILE] [--set KEY=VALUE]... [--out FILE]\n"
    "  FILE: one correspondence a line, 'xs ys zs xt yt zt' [m]\n"
    "  --config: a YAML preset (see config/); --set overrides one parameter, e.g. --set graph.t_cmp=0.995\n"
    "  --out: also write the 4x4 T_target_source there (4 lines of 4 numbers)\n"
    "exit status: 0 registered, 1 registration failed (reason printed), 2 bad arguments or unreadable "
    "input\n";

struct Options {
  std::string correspondences, config, out;
  std::vector<std::string> overrides;
};

Options parseArguments(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--correspondences")
      options.correspondences = value();
    else if (arg == "--config")
      options.config = value();
    else if (arg == "--out")
      options.out = value();
    else if (arg == "--set")
      options.overrides.push_back(value());
    else if (arg == "-h" || arg == "--help") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      throw std::invalid_argument("unexpected argument '" + arg + "' (clouds-in mode is not available yet)");
    }
  }
  if (options.correspondences.empty()) throw std::invalid_argument("--correspondences FILE is required");
  return options;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mac_registration;
  Options options;
  MacParams params;
  Correspondences correspondences;
  try {
    options = parseArguments(argc, argv);
    if (!options.config.empty()) loadParamsFile(params, options.config);
    for (const auto& assignment : options.overrides) {
      const auto eq = assignment.find('=');
      if (eq == std::string::npos)
        throw std::invalid_argument("--set expects KEY=VALUE, got '" + assignment + "'");
      setParam(params, assignment.substr(0, eq), assignment.substr(eq + 1));
    }
    correspondences = readCorrespondencesFile(options.correspondences);
  } catch (const std::exception& e) {
    std::cerr << "mac_register: " << e.what() << "\n" << kUsage;
    return 2;
  }

  const RegistrationResult result = registerCorrespondences(correspondences, params);
  if (result.status == RegistrationStatus::kInvalidParameters) {
    std::cerr << "mac_register: " << result.message << "\n";
    return 2;
  }
  std::cout << "T_target_source:\n" << formatTransform(result.T_target_source);
  printResultSummary(std::cout, result);
  if (!result.success) {
    std::cerr << "mac_register: registration failed: " << toString(result.status) << ": " << result.message
              << "\n";
    return 1;
  }
  if (!options.out.empty()) {
    try {
      writeTransformFile(options.out, result.T_target_source);
    } catch (const std::exception& e) {
      std::cerr << "mac_register: " << e.what() << "\n";
      return 2;
    }
  }
  return 0;
}
