#include "open3d_peer.hpp"

#include <sys/wait.h>

#include <array>
#include <cctype>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace mac_registration {
namespace {

// The script reports "open3d cannot be imported" with this status.
constexpr int kMissingOpen3d = 3;

std::string shellQuoted(const std::string& text) {
  std::string q = "'";
  for (char c : text) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string scriptOf(const Open3dSettings& settings) {
  return settings.script.empty() ? std::string(MAC_OPEN3D_SCRIPT) : settings.script;
}

struct ScriptRun {
  int status = -1;
  std::string output;  // stdout and stderr
};

ScriptRun runScript(const Open3dSettings& settings, const std::vector<std::string>& arguments) {
  std::string command;
  if (settings.threads > 0) command += "OMP_NUM_THREADS=" + std::to_string(settings.threads) + " ";
  command += shellQuoted(settings.python) + " " + shellQuoted(scriptOf(settings));
  for (const std::string& a : arguments) command += " " + shellQuoted(a);
  command += " 2>&1";
  ScriptRun run;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) throw std::runtime_error("cannot start " + settings.python);
  std::array<char, 4096> buffer;
  for (std::size_t n; (n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0;)
    run.output.append(buffer.data(), n);
  const int raw = ::pclose(pipe);
  run.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return run;
}

void throwOnFailure(const Open3dSettings& settings, ScriptRun run) {
  if (run.status == 0) return;
  while (!run.output.empty() && std::isspace(static_cast<unsigned char>(run.output.back())))
    run.output.pop_back();
  if (run.status == kMissingOpen3d)
    throw std::runtime_error(
        "the Open3D baseline needs Debian's python3-open3d (apt-get install python3-open3d) "
        "for " +
        settings.python + ": " + run.output);
  if (run.status == 127)
    throw std::runtime_error("cannot run '" + settings.python + "' (--python): " + run.output);
  throw std::runtime_error(scriptOf(settings) + " failed (exit status " + std::to_string(run.status) +
                           "): " + run.output);
}

// The lines "key value..." of one record; keys the parser does not know (e.g. a library's warning) are
// kept and ignored.
using Record = std::map<std::string, std::string>;

std::vector<Record> records(const std::string& output, const std::string& separator) {
  std::vector<Record> list(1);
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    const auto space = line.find(' ');
    if (space == std::string::npos) continue;
    const std::string key = line.substr(0, space);
    if (key == separator) list.emplace_back();
    list.back()[key] = line.substr(space + 1);
  }
  return list;
}

const std::string& field(const Record& r, const std::string& key) {
  const auto it = r.find(key);
  if (it == r.end()) throw std::runtime_error("the Open3D baseline's output has no '" + key + "' line");
  return it->second;
}

double number(const Record& r, const std::string& key) {
  try {
    return std::stod(field(r, key));
  } catch (const std::logic_error&) {  // invalid_argument, out_of_range
    throw std::runtime_error("the Open3D baseline's '" + key + "' is not a number: '" + field(r, key) + "'");
  }
}

Eigen::Isometry3d transform(const Record& r) {
  std::istringstream in(field(r, "T"));
  Eigen::Matrix4d m;
  for (int k = 0; k < 16; ++k) {
    if (!(in >> m(k / 4, k % 4)))
      throw std::runtime_error("the Open3D baseline's 'T' line needs 16 numbers: '" + field(r, "T") + "'");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.matrix().topRows<3>() = m.topRows<3>();
  return T;
}

}  // namespace

Open3dCloudsRun parseOpen3dClouds(const std::string& output) {
  const Record r = records(output, "").front();
  Open3dCloudsRun run;
  run.version = field(r, "open3d_version");
  run.source_points = std::size_t(number(r, "source_points"));
  run.target_points = std::size_t(number(r, "target_points"));
  run.source_keypoints = std::size_t(number(r, "source_keypoints"));
  run.target_keypoints = std::size_t(number(r, "target_keypoints"));
  run.read_ms = number(r, "read_ms");
  run.downsample_ms = number(r, "downsample_ms");
  run.normals_ms = number(r, "normals_ms");
  run.fpfh_ms = number(r, "fpfh_ms");
  run.registration_ms = number(r, "registration_ms");
  run.total_ms = number(r, "total_ms");
  run.fitness = number(r, "fitness");
  run.inliers = std::size_t(number(r, "inliers"));
  run.T_target_source = transform(r);
  run.peak_mb = number(r, "peak_rss_mb");
  return run;
}

Open3dFgrRuns parseOpen3dFgr(const std::string& output) {
  const std::vector<Record> list = records(output, "file");
  Open3dFgrRuns runs;
  runs.version = field(list.front(), "open3d_version");
  for (std::size_t k = 1; k < list.size(); ++k) {
    FgrRun run;
    run.file = field(list[k], "file");
    run.correspondences = std::size_t(number(list[k], "correspondences"));
    run.fgr_ms = number(list[k], "fgr_ms");
    run.T_target_source = transform(list[k]);
    runs.runs.push_back(run);
  }
  runs.peak_mb = number(list.back(), "peak_rss_mb");  // printed after the last file
  return runs;
}

void requireOpen3d(const Open3dSettings& settings) {
  throwOnFailure(settings, runScript(settings, {"check"}));
}

Open3dCloudsRun runOpen3dClouds(const Open3dSettings& settings, const std::string& source_path,
                                const std::string& target_path, double voxel_size, int seed) {
  std::ostringstream voxel;
  voxel.precision(17);
  voxel << voxel_size;
  const ScriptRun run = runScript(
      settings, {"clouds", source_path, target_path, "--voxel", voxel.str(), "--seed", std::to_string(seed)});
  throwOnFailure(settings, run);
  return parseOpen3dClouds(run.output);
}

Open3dFgrRuns runOpen3dFgr(const Open3dSettings& settings, const std::vector<std::string>& files,
                           double distance) {
  std::ostringstream d;
  d.precision(17);
  d << distance;
  std::vector<std::string> arguments{"fgr", "--distance", d.str()};
  arguments.insert(arguments.end(), files.begin(), files.end());
  const ScriptRun run = runScript(settings, arguments);
  throwOnFailure(settings, run);
  Open3dFgrRuns runs = parseOpen3dFgr(run.output);
  if (runs.runs.size() != files.size())
    throw std::runtime_error("the Open3D baseline reported " + std::to_string(runs.runs.size()) + " of " +
                             std::to_string(files.size()) + " FGR runs");
  return runs;
}

}  // namespace mac_registration
