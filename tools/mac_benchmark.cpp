// mac_benchmark: measures the MAC core (time per stage, peak memory, counters) and its accuracy on
// datasets with ground truth, next to a RANSAC baseline on the same correspondences.
//   mac_benchmark synthetic [--sizes 250,500,...] [--ratios 0.02,0.05,...] [--noise M] [--repeats R]
//                           [--mesh PLY] [--csv FILE] [--config FILE] [--set KEY=VALUE]...
//   mac_benchmark correspondences FILE GT_FILE [--repeats R] [--csv FILE] [--config FILE] [--set ...]
//   mac_benchmark compare ESTIMATE_FILE GT_FILE
//   mac_benchmark pairs TABLE.tsv [dataset options]          (e.g. 3dmatch/pairs_available.tsv)
//   mac_benchmark gtlog FRAGMENT_DIR GT_LOG [--subset-name NAME] [dataset options]   (3DMatch layout)
//   mac_benchmark sets FOLDER|LIST [dataset options]          (correspondence sets with ground truth)
//   mac_benchmark threedmatch FRAGMENTS_ROOT BENCHMARKS_ROOT [--scenes a,b,...] [--benchmarks 3DMatch,...]
//                             [--thresholds 0,0.1,...] [dataset options]   (the whole 3DMatch and 3DLoMatch
//                             benchmarks: FRAGMENTS_ROOT/<scene>/cloud_bin_<k>.ply and
//                             BENCHMARKS_ROOT/<benchmark>/<scene>/gt.log; every scene with both, the others
//                             named and skipped; the MAC paper's table and the successes at each
//                             verification.min_confidence of --thresholds)
//   mac_benchmark verify [TABLE.tsv|FOLDER|LIST]... [--derived] [--synthetic] [--thresholds 0,0.1,...]
//                        [dataset options]   (the labelled evaluation of the verification: pairs with
//                        ground truth or "none"; --derived adds each pair's correspondences without their
//                        near-inliers and with shuffled targets; --synthetic the synthetic grid of
//                        --sizes/--ratios/--repeats and its 0 % and unrelated sets;
//                        --no-cloud-verification judges on the correspondences alone)
//   mac_benchmark relocalize MAP TABLE.tsv [--crop HALF_WIDTH] [--peer-iterations N] [--config FILE]
//                            [--set ...] [--csv FILE] [--limit N]   (queries localized in the map described
//                            once: TABLE lines "name, query file, true T_map_query"; success = benchmark.*
//                            criterion; --crop keeps the map's square of that half-width [m] around the
//                            queries' mean true position; --peer-iterations runs PCL's prerejective RANSAC
//                            beside it)
// dataset options: [--config FILE] [--set KEY=VALUE]... [--csv FILE] [--baseline LIST]
//                  [--ransac-iterations N] [--subset NAME] [--limit N]
// --baseline LIST: comma-separated, of ransac (PCL's RANSAC on our correspondences; the dataset modes'
//   default), open3d (Open3D's own pipeline on the same clouds), fgr (Open3D's FGR on the same
//   correspondences; synthetic and correspondences modes), none. The Open3D peers run
//   tools/benchmark/open3d_baseline.py with [--python /usr/bin/python3] [--open3d-script FILE].
// The synthetic and correspondences modes run each case in a child process so that its peak resident
// memory is its own; the dataset modes print a paper-style recall table (see BENCHMARKS.md).
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "benchmark_runner.hpp"
#include "core_cases.hpp"
#include "mac_registration/config/preset_file.hpp"
#include "mac_registration/core/mac_registration.hpp"
#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/core/text_io.hpp"
#include "open3d_peer.hpp"
#include "paper_table.hpp"
#ifdef MAC_REGISTRATION_WITH_FEATURES
#include "relocalization_eval.hpp"
#endif
#include "synthetic.hpp"
#include "verification_eval.hpp"

namespace mac_registration {
namespace {

struct Options {
  std::vector<int> sizes{250, 500, 1000, 2500, 5000, 10000};
  std::vector<double> ratios{0.02, 0.05, 0.10, 0.50};
  double noise = 0.005;
  int repeats = 5;
  std::string mesh = "test/data/teaser_bun_zipper_res3.ply";
  std::string csv;
  RegistrationConfig config;  // what --config and --set change
  std::vector<std::string> positional;
  // dataset modes
  BenchmarkSettings dataset;  // its mac and features are filled from `config`
  std::string subset_filter, subset_name;
  std::size_t limit = 0;
  // threedmatch mode
  std::vector<std::string> scenes;  // empty: every scene with fragments and a gt.log
  std::vector<std::string> benchmarks{"3DMatch", "3DLoMatch"};
  // verify mode
  bool derived = false, synthetic = false;
  std::vector<double> thresholds{0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9};
  bool fgr = false;         // --baseline fgr, synthetic and correspondences modes
  double crop = 0.0;        // relocalize mode: --crop HALF_WIDTH [m]
  int peer_iterations = 0;  // relocalize mode: --peer-iterations N
};

// The benchmark: section of a preset and --set benchmark.* keys: the success criterion of the recall.
void setBenchmarkParam(BenchmarkSettings& settings, const std::string& key, const std::string& value) {
  double v = 0.0;
  try {
    v = std::stod(value);
  } catch (const std::exception&) {
    throw std::invalid_argument(key + ": '" + value + "' is not a number");
  }
  if (key == "benchmark.max_rotation_error_deg")
    settings.criterion.max_rotation_deg = v;
  else if (key == "benchmark.max_translation_error")
    settings.criterion.max_translation = v;
  else if (key == "benchmark.ransac_max_iterations")
    settings.ransac_max_iterations = int(v);
  else
    throw std::invalid_argument("unknown parameter '" + key + "'");
}

void applySetting(Options& o, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (assignment.rfind("benchmark.", 0) == 0 && eq != std::string::npos)
    setBenchmarkParam(o.dataset, assignment.substr(0, eq), assignment.substr(eq + 1));
  else
    applyAssignment(o.config, assignment);
}

void loadConfig(Options& o, const std::string& path) {
  loadPresetFile(o.config, path, [&](const std::string& key, const std::string& value) {
    if (key.rfind("benchmark.", 0) == 0) setBenchmarkParam(o.dataset, key, value);
  });
}

template <typename Run>
CaseResult measure(int repeats, Run run_once) {
  std::vector<std::vector<double>> stage(13);
  CaseResult r;
  r.repeats = repeats;
  for (int k = 0; k < repeats; ++k) {
    Eigen::Isometry3d truth;
    const MacResult result = run_once(k, truth);
    const StageTimes& t = result.times;
    const double values[] = {t.graph_ms,
                             t.second_order_ms,
                             t.clique_search_ms,
                             t.selection_ms,
                             t.hypotheses_ms,
                             t.evaluation_ms,
                             t.refinement_ms,
                             t.total_ms,
                             double(result.counters.cliques),
                             double(result.counters.selected_cliques),
                             double(result.counters.inliers),
                             double(result.counters.graph_edges),
                             t.verification_ms};
    for (int s = 0; s < 13; ++s) stage[s].push_back(values[s]);
    r.successes += result.success;
    r.incomplete += !result.clique_search_complete;
    if (result.success) {
      r.max_re = std::max(r.max_re, rotationErrorDeg(result.T_target_source, truth));
      r.max_te = std::max(r.max_te, translationError(result.T_target_source, truth));
    }
  }
  double* fields[] = {&r.graph,      &r.second_order, &r.cliques,     &r.selection,    &r.hypotheses,
                      &r.evaluation, &r.refinement,   &r.total,       &r.clique_count, &r.selected,
                      &r.inliers,    &r.edges,        &r.verification};
  for (int s = 0; s < 13; ++s) *fields[s] = median(stage[s]);
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  r.peak_mb = usage.ru_maxrss / 1024.0;
  return r;
}

// Runs `work` in a child so that the peak memory it reports is the case's alone (libgomp's thread pool
// does not survive fork, so the parent itself never registers anything).
template <typename Work>
CaseResult inChild(Work work) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    CaseResult r = work();
    const ssize_t written = write(fds[1], &r, sizeof r);
    _exit(written == sizeof r ? 0 : 1);
  }
  close(fds[1]);
  CaseResult r;
  const ssize_t got = read(fds[0], &r, sizeof r);
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (got != sizeof r || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("benchmark case crashed");
  return r;
}

// Writes each repeat's correspondence set for FGR, runs it once on all of them and judges each
// transform against its truth.
PeerCase runFgr(const Options& o, const std::vector<CorrespondenceSet>& sets,
                const std::vector<Eigen::Isometry3d>& truths) {
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("mac_benchmark_fgr_" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  std::vector<std::string> files;
  for (std::size_t k = 0; k < sets.size(); ++k) {
    files.push_back((folder / ("set_" + std::to_string(k) + ".txt")).string());
    std::ofstream out(files.back());
    out << std::setprecision(9);
    for (Eigen::Index c = 0; c < sets[k].source_points.cols(); ++c)
      out << sets[k].source_points.col(c).transpose() << " " << sets[k].target_points.col(c).transpose()
          << "\n";
    if (!out) throw std::runtime_error("cannot write '" + files.back() + "'");
  }
  Open3dFgrRuns runs;
  try {
    runs = runOpen3dFgr(o.dataset.open3d_settings, files, o.config.mac.evaluation.inlier_threshold);
  } catch (...) {
    std::filesystem::remove_all(folder);
    throw;
  }
  std::filesystem::remove_all(folder);
  PeerCase peer;
  peer.ran = true;
  peer.repeats = int(sets.size());
  peer.peak_mb = runs.peak_mb;
  std::vector<double> times, re, te;
  for (std::size_t k = 0; k < runs.runs.size(); ++k) {
    times.push_back(runs.runs[k].fgr_ms);
    re.push_back(rotationErrorDeg(runs.runs[k].T_target_source, truths[k]));
    te.push_back(translationError(runs.runs[k].T_target_source, truths[k]));
    peer.recalled += o.dataset.criterion.accepts(re.back(), te.back());
  }
  peer.ms = median(times);
  peer.median_re = median(re);
  peer.median_te = median(te);
  return peer;
}

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');) parts.push_back(part);
  return parts;
}

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--sizes") {
      o.sizes.clear();
      for (const auto& s : split(value())) o.sizes.push_back(std::stoi(s));
    } else if (arg == "--ratios") {
      o.ratios.clear();
      for (const auto& s : split(value())) o.ratios.push_back(std::stod(s));
    } else if (arg == "--noise")
      o.noise = std::stod(value());
    else if (arg == "--repeats")
      o.repeats = std::max(1, std::stoi(value()));
    else if (arg == "--mesh")
      o.mesh = value();
    else if (arg == "--csv")
      o.csv = value();
    else if (arg == "--config")
      loadConfig(o, value());
    else if (arg == "--set")
      applySetting(o, value());
    else if (arg == "--baseline") {
      o.dataset.baseline = o.dataset.open3d = o.fgr = false;
      for (const std::string& b : split(value())) {
        if (b == "ransac")
          o.dataset.baseline = true;
        else if (b == "open3d")
          o.dataset.open3d = true;
        else if (b == "fgr")
          o.fgr = true;
        else if (b != "none")
          throw std::invalid_argument(
              "--baseline takes ransac, open3d, fgr or none (comma-separated), not '" + b + "'");
      }
    } else if (arg == "--python")
      o.dataset.open3d_settings.python = value();
    else if (arg == "--open3d-script")
      o.dataset.open3d_settings.script = value();
    else if (arg == "--ransac-iterations")
      o.dataset.ransac_max_iterations = std::stoi(value());
    else if (arg == "--subset")
      o.subset_filter = value();
    else if (arg == "--subset-name")
      o.subset_name = value();
    else if (arg == "--limit")
      o.limit = std::stoul(value());
    else if (arg == "--crop")
      o.crop = std::stod(value());
    else if (arg == "--peer-iterations")
      o.peer_iterations = std::stoi(value());
    else if (arg == "--scenes")
      o.scenes = split(value());
    else if (arg == "--benchmarks")
      o.benchmarks = split(value());
    else if (arg == "--derived")
      o.derived = true;
    else if (arg == "--synthetic")
      o.synthetic = true;
    else if (arg == "--no-cloud-verification")
      o.dataset.cloud_verification = false;
    else if (arg == "--thresholds") {
      o.thresholds.clear();
      for (const auto& s : split(value())) o.thresholds.push_back(std::stod(s));
    } else if (!arg.empty() && arg[0] == '-')
      throw std::invalid_argument("unknown option " + arg);
    else
      o.positional.push_back(arg);
  }
  return o;
}

// The synthetic scene: the bunny scaled to a 3 m object, 5 mm noise by default; graph and evaluation
// thresholds follow the noise unless --config/--set gave others.
// Opens a CSV output before a long run, creating its folder (the documented commands write into build/),
// and refuses loudly instead of dropping the results.
std::ofstream openCsv(const std::string& path) {
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  if (!folder.empty()) std::filesystem::create_directories(folder);
  std::ofstream csv(path);
  if (!csv) throw std::runtime_error("cannot open '" + path + "' for writing");
  return csv;
}

// Repeat k (seed k + 1) of the synthetic case of n correspondences.
SyntheticProblem syntheticCase(const TriangleMesh& mesh, int n, double ratio, double noise, int k) {
  SyntheticSpec spec;
  spec.correspondences = n;
  spec.inlier_ratio = ratio;
  spec.noise_sigma = noise;
  spec.object_size = 3.0;
  spec.seed = static_cast<std::uint32_t>(k + 1);
  return makeSyntheticProblem(mesh, spec);
}

void printFgrSettings(std::ostream& out, const Options& o) {
  out << "FGR (Open3D registration_fgr_based_on_correspondence) on the same sets: absolute scale, "
         "maximum_correspondence_distance = tau = "
      << o.config.mac.evaluation.inlier_threshold
      << " m, Open3D's other defaults; recalled: RE <= " << o.dataset.criterion.max_rotation_deg
      << " deg and TE <= " << o.dataset.criterion.max_translation << " m\n";
}

int runSynthetic(Options o, bool params_given) {
  const TriangleMesh mesh = readAsciiPlyMesh(o.mesh);
  if (!params_given) {
    o.config.mac.graph.gaussian_sigma = 50.0 * o.noise;
    o.config.mac.evaluation.inlier_threshold = 10.0 * o.noise;
  }
  if (o.fgr) requireOpen3d(o.dataset.open3d_settings);
  std::ofstream csv;
  if (!o.csv.empty()) {
    csv = openCsv(o.csv);
    csv << coreCsvHeader() << "\n";
  }
  std::cout << "synthetic: bunny mesh scaled to 3 m, noise " << o.noise << " m, " << o.repeats
            << " repeats per case (seeds 1..), gaussian_sigma " << o.config.mac.graph.gaussian_sigma
            << " m, t_cmp " << o.config.mac.graph.t_cmp << ", tau "
            << o.config.mac.evaluation.inlier_threshold << " m\n";
  if (o.fgr) printFgrSettings(std::cout, o);
  printTableHeader(std::cout, o.fgr);
  std::vector<std::pair<std::string, CaseResult>> cases;
  for (int n : o.sizes) {
    for (double ratio : o.ratios) {
      const CaseResult r = inChild([&] {
        return measure(o.repeats, [&](int k, Eigen::Isometry3d& truth) {
          const SyntheticProblem problem = syntheticCase(mesh, n, ratio, o.noise, k);
          truth = problem.T_target_source;
          return registerCorrespondences(problem.correspondences, o.config.mac);
        });
      });
      PeerCase fgr;
      if (o.fgr) {  // the same sets again: the generator is seeded
        std::vector<CorrespondenceSet> sets;
        std::vector<Eigen::Isometry3d> truths;
        for (int k = 0; k < o.repeats; ++k) {
          SyntheticProblem problem = syntheticCase(mesh, n, ratio, o.noise, k);
          sets.push_back(std::move(problem.correspondences));
          truths.push_back(problem.T_target_source);
        }
        fgr = runFgr(o, sets, truths);
      }
      printRow(std::cout, "synthetic", n, ratio, r, fgr);
      if (csv.is_open()) writeCsvRow(csv, "synthetic", n, ratio, o.noise, r, fgr);
      std::ostringstream name;
      name << "N " << n << ", " << ratio * 100 << " %";
      cases.emplace_back(name.str(), r);
    }
  }
  printShares(std::cout, cases);
  return 0;
}

int runCorrespondences(const Options& o) {
  if (o.positional.size() != 2) throw std::invalid_argument("correspondences needs FILE GT_FILE");
  const CorrespondenceSet c = readCorrespondencesFile(o.positional[0]);
  const Eigen::Isometry3d gt = readTransformFile(o.positional[1]);
  if (o.fgr) requireOpen3d(o.dataset.open3d_settings);
  const CaseResult r = inChild([&] {
    return measure(o.repeats, [&](int, Eigen::Isometry3d& truth) {
      truth = gt;
      return registerCorrespondences(c, o.config.mac);
    });
  });
  // FGR is deterministic on one set: as many runs as ours, for a median of as many times.
  const PeerCase fgr = o.fgr ? runFgr(o, std::vector<CorrespondenceSet>(std::size_t(o.repeats), c),
                                      std::vector<Eigen::Isometry3d>(std::size_t(o.repeats), gt))
                             : PeerCase{};
  std::cout << "correspondences: " << o.positional[0] << " (" << c.size() << "), " << o.repeats
            << " repeats\n";
  if (o.fgr) printFgrSettings(std::cout, o);
  printTableHeader(std::cout, o.fgr);
  printRow(std::cout, "file", int(c.size()), 0.0, r, fgr);
  printShares(std::cout, {{"file", r}});
  if (!o.csv.empty()) {
    std::ofstream csv = openCsv(o.csv);
    csv << coreCsvHeader() << "\n";
    writeCsvRow(csv, o.positional[0], int(c.size()), 0.0, 0.0, r, fgr);
  }
  return r.successes == r.repeats ? 0 : 1;
}

int runCompare(const Options& o) {
  if (o.positional.size() != 2) throw std::invalid_argument("compare needs ESTIMATE_FILE GT_FILE");
  const Eigen::Isometry3d estimate = readTransformFile(o.positional[0]);
  const Eigen::Isometry3d truth = readTransformFile(o.positional[1]);
  const double re = rotationErrorDeg(estimate, truth), te = translationError(estimate, truth);
  const bool ok = re <= 15.0 && te <= 0.30;
  std::cout << std::fixed << std::setprecision(3) << "error against ground truth: rotation " << re
            << " deg, translation " << te * 100.0 << " cm -> " << (ok ? "within" : "OUTSIDE")
            << " the 3DMatch criterion (RE <= 15 deg, TE <= 30 cm)\n";
  return ok ? 0 : 1;
}

// With `paper_table`, also the MAC paper's table per benchmark and scene, and the successes at each of
// --thresholds.
int runDataset(Options o, std::vector<BenchmarkPair> pairs, const std::string& source,
               bool paper_table = false) {
  if (!o.subset_filter.empty()) {
    pairs.erase(std::remove_if(pairs.begin(), pairs.end(),
                               [&](const BenchmarkPair& p) { return p.subset != o.subset_filter; }),
                pairs.end());
  }
  if (o.limit > 0 && pairs.size() > o.limit) pairs.resize(o.limit);
  if (pairs.empty()) throw std::invalid_argument("no pairs to evaluate in " + source);
  std::ofstream csv;
  if (!o.csv.empty()) {
    csv = openCsv(o.csv);  // now rather than after a long run
  }
  const bool baseline = o.dataset.baseline && benchmarkHasFeatures();
  if (o.fgr) throw std::invalid_argument("--baseline fgr is for the synthetic and correspondences modes");
  if (o.dataset.open3d) requireOpen3d(o.dataset.open3d_settings);
  std::cout << "dataset: " << source << ", " << pairs.size() << " pairs\n";
  printDatasetSettings(std::cout, o.config, o.dataset, baseline);
  o.dataset.mac = o.config.mac;
  o.dataset.features = o.config.features;
  o.dataset.baseline = baseline;

  std::vector<PairOutcome> outcomes;
  std::size_t errors = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    outcomes.push_back(runBenchmarkPair(pairs[k], o.dataset));
    errors += !outcomes.back().error.empty();
    printPairProgress(std::cerr, k, pairs.size(), outcomes.back());
  }
  std::cout << "\n";
  printSummary(std::cout, summarize(outcomes), o.dataset.criterion);
  printPeerComparison(std::cout, outcomes, "MAC", "Open3D");
  if (paper_table) {
    const GrossError gross;
    const VerificationParams& verification = o.config.mac.verification;
    // Without the verification a success has no confidence to re-threshold.
    const std::vector<ThresholdRow> thresholds = verification.enabled
                                                     ? thresholdRows(outcomes, "MAC", o.thresholds, gross)
                                                     : std::vector<ThresholdRow>{};
    std::cout << "\n";
    printPaperTable(std::cout, paperRows(outcomes, "MAC", gross, true), thresholds,
                    verification.min_confidence, o.dataset.criterion, gross);
  }
  if (errors > 0)
    std::cout << errors << " pairs could not be run (counted as misses; see the progress lines)\n";
  if (csv.is_open()) {
    writeOutcomesCsv(csv, outcomes);
    if (!csv) throw std::runtime_error("failed writing '" + o.csv + "'");
    std::cout << "per-pair results: " << o.csv << "\n";
  }
  return errors > 0 ? 1 : 0;
}

int runPairs(const Options& o) {
  if (o.positional.size() != 1) throw std::invalid_argument("pairs needs TABLE.tsv");
  return runDataset(o, readPairsTable(o.positional[0]), o.positional[0]);
}

int runGtLog(const Options& o) {
  if (o.positional.size() != 2) throw std::invalid_argument("gtlog needs FRAGMENT_DIR GT_LOG");
  std::vector<std::string> missing;
  // The benchmark's name is the gt.log's grandparent folder in the 3DMatch layout
  // (benchmarks/3DLoMatch/<scene>/gt.log); --subset-name overrides it.
  const std::string subset = !o.subset_name.empty() ? o.subset_name
                                                    : std::filesystem::path(o.positional[1])
                                                          .lexically_normal()
                                                          .parent_path()
                                                          .parent_path()
                                                          .filename()
                                                          .string();
  std::vector<BenchmarkPair> pairs = pairsFromGtLog(o.positional[0], o.positional[1], subset, missing);
  if (!missing.empty()) {
    std::cout << "skipped " << missing.size() << " gt.log pairs whose fragments are not in "
              << o.positional[0] << "\n";
  }
  return runDataset(o, pairs, o.positional[1]);
}

// The pairs of every benchmark's scenes that have fragments: BENCHMARKS_ROOT/<benchmark>/<scene>/gt.log with
// FRAGMENTS_ROOT/<scene>/. Says which scenes and pairs it leaves out, and why.
int runThreeDMatch(const Options& o) {
  namespace fs = std::filesystem;
  if (o.positional.size() != 2)
    throw std::invalid_argument("threedmatch needs FRAGMENTS_ROOT BENCHMARKS_ROOT");
  const fs::path fragments = o.positional[0], benchmarks = o.positional[1];
  std::set<std::string> unmatched(o.scenes.begin(), o.scenes.end());
  std::vector<BenchmarkPair> pairs;
  for (const std::string& benchmark : o.benchmarks) {
    const fs::path folder = benchmarks / benchmark;
    if (!fs::is_directory(folder))
      throw std::invalid_argument("no benchmark folder '" + folder.string() + "'");
    std::vector<std::string> scenes;
    for (const auto& entry : fs::directory_iterator(folder)) {
      const std::string scene = entry.path().filename().string();
      if (fs::exists(entry.path() / "gt.log") &&
          (o.scenes.empty() || std::find(o.scenes.begin(), o.scenes.end(), scene) != o.scenes.end()))
        scenes.push_back(scene);
    }
    std::sort(scenes.begin(), scenes.end());  // directory order is the file system's
    std::vector<std::string> run, without_fragments;
    for (const std::string& scene : scenes) {
      unmatched.erase(scene);
      if (!fs::is_directory(fragments / scene)) {
        without_fragments.push_back(scene);
        continue;
      }
      std::vector<std::string> missing;
      const std::vector<BenchmarkPair> scene_pairs = pairsFromGtLog(
          (fragments / scene).string(), (folder / scene / "gt.log").string(), benchmark, missing);
      if (!missing.empty())
        std::cout << benchmark << " " << scene << ": skipped " << missing.size() << " of "
                  << missing.size() + scene_pairs.size() << " pairs, a fragment missing (first " << missing[0]
                  << ")\n";
      pairs.insert(pairs.end(), scene_pairs.begin(), scene_pairs.end());
      run.push_back(scene);
    }
    std::cout << benchmark << ": " << run.size() << " of " << scenes.size() << " scenes with a gt.log";
    if (!without_fragments.empty()) {
      std::cout << "; skipped, no fragments in " << fragments.string() << ":";
      for (const std::string& scene : without_fragments) std::cout << " " << scene;
    }
    std::cout << "\n";
  }
  if (!unmatched.empty())
    throw std::invalid_argument("--scenes: no gt.log of the benchmarks for '" + *unmatched.begin() + "'");
  return runDataset(o, pairs, benchmarks.string(), true);
}

int runSets(const Options& o) {
  if (o.positional.size() != 1) throw std::invalid_argument("sets needs FOLDER or LIST");
  return runDataset(o, readCorrespondenceSets(o.positional[0]), o.positional[0]);
}

int runVerify(Options o, bool params_given) {
  std::vector<BenchmarkPair> pairs;
  for (const std::string& source : o.positional) {
    const bool table = std::filesystem::path(source).extension() == ".tsv";
    for (const BenchmarkPair& p : table ? readPairsTable(source) : readCorrespondenceSets(source))
      pairs.push_back(p);
  }
  if (pairs.empty() && !o.synthetic) throw std::invalid_argument("verify needs tables or --synthetic");
  std::ofstream csv;
  if (!o.csv.empty()) csv = openCsv(o.csv);
  o.dataset.mac = o.config.mac;
  o.dataset.features = o.config.features;
  std::vector<VerificationCase> cases;
  for (const BenchmarkPair& pair : pairs) {
    for (VerificationCase& c : runVerificationPair(pair, o.dataset, o.derived)) {
      printVerificationCase(std::cerr, c);
      cases.push_back(std::move(c));
    }
  }
  if (o.synthetic) {
    MacParams mac = o.config.mac;
    if (!params_given) {
      mac.graph.gaussian_sigma = 50.0 * o.noise;
      mac.evaluation.inlier_threshold = 10.0 * o.noise;
    }
    for (VerificationCase& c :
         runSyntheticVerification(readAsciiPlyMesh(o.mesh), o.sizes, o.ratios, o.noise, o.repeats, mac)) {
      printVerificationCase(std::cerr, c);
      cases.push_back(std::move(c));
    }
  }
  std::cout << "\n"
            << cases.size() << " cases; verification.min_confidence "
            << o.config.mac.verification.min_confidence << "\n";
  printOperatingPoints(std::cout, cases, o.thresholds, o.config.mac.verification.min_confidence);
  std::cout << "\nat min_confidence " << o.config.mac.verification.min_confidence << ":\n";
  printCasesByKind(std::cout, cases, o.config.mac.verification.min_confidence);
  if (csv.is_open()) {
    writeVerificationCsv(csv, cases);
    std::cout << "per-case results: " << o.csv << "\n";
  }
  return 0;
}

#ifdef MAC_REGISTRATION_WITH_FEATURES
int runRelocalize(const Options& o) {
  if (o.positional.size() != 2) throw std::invalid_argument("relocalize needs MAP TABLE.tsv");
  RelocalizationSettings settings;
  settings.config = o.config;
  settings.max_rotation_deg = o.dataset.criterion.max_rotation_deg;
  settings.max_translation = o.dataset.criterion.max_translation;
  settings.crop_half_width = o.crop;
  settings.peer_iterations = o.peer_iterations;
  std::vector<RelocalizationQuery> queries = readRelocalizationTable(o.positional[1]);
  if (o.limit > 0 && queries.size() > o.limit) queries.resize(o.limit);
  std::ofstream csv;
  if (!o.csv.empty()) csv = openCsv(o.csv);
  return runRelocalizationBenchmark(o.positional[0], queries, settings, std::cout,
                                    csv.is_open() ? &csv : nullptr);
}
#endif

}  // namespace
}  // namespace mac_registration

int main(int argc, char** argv) {
  using namespace mac_registration;
  const std::string usage =
      "usage: mac_benchmark MODE ...\n"
      "  mac_benchmark synthetic [--sizes 250,500,...] [--ratios 0.02,0.05,...] [--noise M] [--repeats R]\n"
      "                          [--mesh PLY] [--csv FILE] [--config FILE] [--set KEY=VALUE]...\n"
      "  mac_benchmark correspondences FILE GT_FILE [--repeats R] [--csv FILE] [--config FILE] [--set ...]\n"
      "  mac_benchmark compare ESTIMATE_FILE GT_FILE\n"
      "  mac_benchmark pairs TABLE.tsv [dataset options]\n"
      "  mac_benchmark gtlog FRAGMENT_DIR GT_LOG [--subset-name NAME] [dataset options]\n"
      "  mac_benchmark sets FOLDER|LIST [dataset options]\n"
      "  mac_benchmark threedmatch FRAGMENTS_ROOT BENCHMARKS_ROOT [--scenes a,b,...] [--benchmarks "
      "3DMatch,...]\n"
      "                            [--thresholds 0,0.1,...] [dataset options]\n"
      "  mac_benchmark verify [TABLE.tsv|FOLDER|LIST]... [--derived] [--synthetic] [--thresholds 0,0.1,...]\n"
      "                       [--no-cloud-verification] [dataset options]\n"
      "  mac_benchmark relocalize MAP TABLE.tsv [--crop HALF_WIDTH] [--peer-iterations N] [--config FILE]\n"
      "                           [--set KEY=VALUE]... [--csv FILE] [--limit N]\n"
      "dataset options: [--config FILE] [--set KEY=VALUE]... [--csv FILE] [--baseline "
      "ransac,open3d,fgr|none]\n"
      "                 [--ransac-iterations N] [--subset NAME] [--limit N]\n"
      "BENCHMARKS.md shows each mode with its data and its table.\n";
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "-h" || std::string(argv[i]) == "--help") {
      std::cout << usage;
      return 0;
    }
  }
  if (argc < 2) {
    std::cerr << usage;
    return 2;
  }
  const std::string mode = argv[1];
  try {
    Options options = parseOptions(argc, argv);
    // The peers get as many threads as ours (0: each library's default, all cores).
    options.dataset.open3d_settings.threads = options.config.mac.num_threads;
    bool params_given = false;
    for (int i = 2; i < argc; ++i)
      params_given |= std::string(argv[i]) == "--config" || std::string(argv[i]) == "--set";
    // Times depend on the kernels; the header says which ran.
    if (mode != "compare") std::cout << "kernels: " << kernelsInUse() << "\n";
    if (mode == "synthetic") return runSynthetic(options, params_given);
    if (mode == "correspondences") return runCorrespondences(options);
    if (mode == "compare") return runCompare(options);
    if (mode == "pairs") return runPairs(options);
    if (mode == "gtlog") return runGtLog(options);
    if (mode == "sets") return runSets(options);
    if (mode == "threedmatch") return runThreeDMatch(options);
    if (mode == "verify") return runVerify(options, params_given);
#ifdef MAC_REGISTRATION_WITH_FEATURES
    if (mode == "relocalize") return runRelocalize(options);
#endif
    std::cerr << "mac_benchmark: unknown mode '" << mode << "'\n" << usage;
  } catch (const std::exception& e) {
    std::cerr << "mac_benchmark: " << e.what() << "\n";
  }
  return 2;
}
