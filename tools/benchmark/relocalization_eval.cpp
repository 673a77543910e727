#include "relocalization_eval.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "mac_registration/core/pose_error.hpp"
#include "mac_registration/features/cloud_io.hpp"
#include "mac_registration/features/map_relocalization.hpp"
#include "process_memory.hpp"
#include "relocalization_peer.hpp"

namespace mac_registration {

namespace {

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

PointCloud::Ptr cropped(const PointCloud& map, const Eigen::Vector3d& centre, double half_width) {
  PointCloud::Ptr out(new PointCloud);
  for (const auto& p : map) {
    if (std::abs(p.x - centre.x()) <= half_width && std::abs(p.y - centre.y()) <= half_width)
      out->push_back(p);
  }
  return out;
}

}  // namespace

std::vector<RelocalizationQuery> readRelocalizationTable(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot read '" + path + "'");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::vector<RelocalizationQuery> queries;
  std::string line;
  std::getline(in, line);  // the header
  int number = 1;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    RelocalizationQuery q;
    std::string matrix;
    if (!std::getline(fields, q.name, '\t') || !std::getline(fields, q.path, '\t') ||
        !std::getline(fields, matrix))
      throw std::invalid_argument(path + ":" + std::to_string(number) +
                                  ": expected name, query, T_map_query");
    std::istringstream numbers(matrix);
    Eigen::Matrix4d T;
    for (int k = 0; k < 16; ++k) {
      if (!(numbers >> T(k / 4, k % 4)))
        throw std::invalid_argument(path + ":" + std::to_string(number) + ": T_map_query needs 16 numbers");
    }
    q.T_map_query.matrix() = T;
    if (std::filesystem::path(q.path).is_relative()) q.path = (folder / q.path).string();
    queries.push_back(q);
  }
  return queries;
}

int runRelocalizationBenchmark(const std::string& map_path, const std::vector<RelocalizationQuery>& queries,
                               const RelocalizationSettings& s, std::ostream& out, std::ostream* csv) {
  resetPeakMemory();
  const LocalCloud file = loadLocalCloud(map_path);
  PointCloud::Ptr map = file.cloud;
  if (s.crop_half_width > 0.0 && !queries.empty()) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const auto& q : queries) centre += q.T_map_query.translation();
    map = cropped(*map, centre / double(queries.size()) - file.origin, s.crop_half_width);
  }
  const DescribedMap described =
      describeMap(*map, s.config.features, s.config.relocalization, nullptr, file.origin);
  const double map_memory = peakMemoryMb();
  out << std::fixed << std::setprecision(1) << "map: " << map->size() << " points, "
      << described.cloud.keypoints->size() << " keypoints, described in " << described.describe_ms / 1e3
      << " s, peak memory " << map_memory << " MiB\n";
  if (csv) {
    *csv << "name,outcome,right,rotation_error_deg,translation_error_m,confidence,chosen,truth_rank,"
            "registered,query_keypoints,query_radius_m,describe_ms,ranking_ms,registration_ms,total_ms,"
            "inliers,"
            "fine_converged,fine_move,std_translation_m,std_rotation_deg,rival_place_ratio\n";
  }
  std::size_t right = 0, wrong = 0, unverified = 0, ambiguous = 0, truth_in_candidates = 0;
  std::vector<double> times;
  std::unique_ptr<RansacPeer> peer;
  std::size_t peer_right = 0, peer_wrong = 0;
  std::vector<double> peer_times;
  if (s.peer_iterations > 0) {
    const double tau = s.config.mac.evaluation.inlier_threshold > 0.0
                           ? s.config.mac.evaluation.inlier_threshold
                           : kInlierThresholdVoxels * s.config.features.voxel_size;
    peer = std::make_unique<RansacPeer>(described, s.peer_iterations, tau);
    out << "peer (PCL SampleConsensusPrerejective, " << s.peer_iterations << " iterations): map set up in "
        << peer->setup_ms / 1e3 << " s\n";
  }
  for (const RelocalizationQuery& q : queries) {
    const PointCloud::Ptr cloud = loadCloud(q.path);
    const RelocalizationResult r =
        relocalize(described, *cloud, s.config.features, s.config.mac, s.config.relocalization);
    const double re = rotationErrorDeg(r.T_map_query, q.T_map_query);
    const double te = translationError(r.T_map_query, q.T_map_query);
    const bool within = re <= s.max_rotation_deg && te <= s.max_translation;
    // The best-ranked place whose centre lies within the query's reach of its true position.
    int truth_rank = -1;
    for (int k = 0; k < int(r.candidates.size()) && truth_rank < 0; ++k) {
      const Eigen::Vector2d d = (r.candidates[k].centre - q.T_map_query.translation()).head<2>();
      if (d.norm() <= r.query_radius) truth_rank = k;
    }
    truth_in_candidates += truth_rank >= 0 && truth_rank < int(s.config.relocalization.max_candidates);
    if (r.success) {
      (within ? right : wrong) += 1;
    } else if (r.outcome == RelocalizationOutcome::kAmbiguous) {
      ++ambiguous;
    } else {
      ++unverified;
    }
    times.push_back(r.total_ms);
    std::string peer_text;
    if (peer) {
      const RansacPeer::Answer a = peer->localize(*cloud, s.config.features);
      const double peer_re = rotationErrorDeg(a.T_map_query, q.T_map_query);
      const double peer_te = translationError(a.T_map_query, q.T_map_query);
      const bool peer_within = peer_re <= s.max_rotation_deg && peer_te <= s.max_translation;
      if (a.converged) (peer_within ? peer_right : peer_wrong) += 1;
      peer_times.push_back(a.ms);
      std::ostringstream text;
      text << std::fixed << std::setprecision(1) << " | peer "
           << (a.converged ? "converged" : "not converged") << " RE " << peer_re << " TE " << peer_te
           << (a.converged ? (peer_within ? " right" : " WRONG") : "") << std::setprecision(0) << " " << a.ms
           << " ms";
      peer_text = text.str();
    }
    out << q.name << ": " << toString(r.outcome) << std::setprecision(2) << " conf " << r.confidence
        << std::setprecision(1) << " RE " << re << " TE " << te
        << (r.success ? (within ? " right" : " WRONG") : "") << " truth rank " << truth_rank
        << std::setprecision(0) << " | " << r.total_ms << " ms (describe " << r.describe_ms << ", rank "
        << r.ranking_ms << ", register " << r.registration_ms << ")"
        << (r.message.empty() ? "" : " | " + r.message) << peer_text << std::endl;
    if (csv) {
      std::size_t registered = 0;
      for (const auto& c : r.candidates) registered += c.registered;
      *csv << std::setprecision(6) << q.name << "," << toString(r.outcome) << "," << (r.success && within)
           << "," << re << "," << te << "," << r.confidence << "," << r.chosen << "," << truth_rank << ","
           << registered << "," << r.query_keypoints << "," << r.query_radius << "," << r.describe_ms << ","
           << r.ranking_ms << "," << r.registration_ms << "," << r.total_ms;
      if (r.chosen >= 0) {
        const MacResult& m = r.candidates[r.chosen].registration.registration;
        const auto& c = m.fine_alignment.covariance;
        *csv << "," << m.counters.inliers << "," << m.fine_alignment.converged << ","
             << m.fine_alignment.displacement << "," << std::sqrt(c.diagonal().head<3>().maxCoeff()) << ","
             << std::sqrt(c.diagonal().tail<3>().maxCoeff()) * 180.0 / M_PI;
        // The best score of a place farther than the query's reach from the pose found, over the chosen
        // one's.
        double rival = 0.0;
        for (const auto& other : r.candidates) {
          if ((other.centre - r.T_map_query.translation()).head<2>().norm() > r.query_radius)
            rival = std::max(rival, other.score);
        }
        *csv << "," << rival / std::max(1.0, r.candidates[r.chosen].score);
      } else {
        *csv << ",,,,,,";
      }
      *csv << "\n";
    }
  }
  const double n = double(std::max<std::size_t>(1, queries.size()));
  out << std::setprecision(1) << "\n"
      << queries.size() << " queries: localized right " << right << " (" << 100.0 * right / n << " %), WRONG "
      << wrong << ", ambiguous " << ambiguous << ", not localized " << unverified
      << "; true place among the registered candidates " << truth_in_candidates << "\n"
      << "map described in " << described.describe_ms / 1e3 << " s (peak memory " << map_memory
      << " MiB); query time median " << std::setprecision(0) << median(times) << " ms, peak memory "
      << std::setprecision(1) << peakMemoryMb() << " MiB\n";
  if (peer) {
    out << "peer: right " << peer_right << " (" << 100.0 * peer_right / n << " %), WRONG " << peer_wrong
        << ", not converged " << queries.size() - peer_right - peer_wrong << "; map set up in "
        << peer->setup_ms / 1e3 << " s, query time median " << std::setprecision(0) << median(peer_times)
        << " ms\n";
  }
  out.unsetf(std::ios::fixed);
  return 0;
}

}  // namespace mac_registration
