#include "mac_registration/features/cloud_verification.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "fine_alignment.hpp"
#include "mac_registration/features/cloud_filtering.hpp"
#include "radius_search.hpp"
#include "verification.hpp"

namespace mac_registration {
namespace {

// Where a cloud's sensor saw through, on a grid of azimuth and elevation from its viewpoint: in each
// direction, the range short of which a point lies in space the sensor saw as empty. That is the nearest
// surface seen there less its uncertainty along the ray: tau across the surface, and for the ground seen
// at a grazing angle tau / cos(incidence) along the ray (up to kGrazingCosine). A lidar a metre or two above
// a road sees it at 5-15 deg, where a point 0.1 m above the ground lies 0.5-1 m nearer than the ground along
// its ray: sparse keyframes' right poses were refused for it (doc/decisions/sparse-keyframes-free-space.md).
// Walls and furniture keep tau: indoors, slanted surfaces' free space is what refuses turned rooms.
class RangeImage {
 public:
  RangeImage(const PointCloud& cloud, const pcl::PointCloud<pcl::Normal>* normals,
             const Eigen::Vector3f& viewpoint, double bin_rad, double tau)
      : viewpoint_(viewpoint), bin_(bin_rad) {
    cols_ = std::max(1, int(std::ceil(2.0 * M_PI / bin_)));
    rows_ = std::max(1, int(std::ceil(M_PI / bin_)));
    boundary_.assign(std::size_t(cols_) * rows_, kUnseen);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      int r = 0, c = 0;
      float range = 0.0f;
      const Eigen::Vector3f p = cloud[i].getVector3fMap();
      if (!cell(p, r, c, range)) continue;
      float margin = float(tau);
      if (normals) {
        const Eigen::Vector3f n = (*normals)[i].getNormalVector3fMap();
        const float incidence_cosine = std::abs(n.dot(p - viewpoint_)) / range;
        if (std::isfinite(incidence_cosine) && std::abs(n.z()) >= kGroundNormalCosine)
          margin = float(tau) / std::max(incidence_cosine, kGrazingCosine);
      }
      float& b = boundary_[index(r, c)];
      b = std::min(b, range - margin);
    }
  }

  // False where the sensor did not look towards `point`; else the nearest boundary in the 3 x 3 cells
  // around that direction (a point beside an edge is not in front of the far side) and the point's range.
  bool lookup(const Eigen::Vector3f& point, float& boundary, float& range) const {
    int r = 0, c = 0;
    if (!cell(point, r, c, range) || boundary_[index(r, c)] == kUnseen) return false;
    boundary = kUnseen;
    for (int rr = std::max(0, r - 1); rr <= std::min(rows_ - 1, r + 1); ++rr) {
      for (int dc = -1; dc <= 1; ++dc)
        boundary = std::min(boundary, boundary_[index(rr, (c + dc + cols_) % cols_)]);
    }
    return true;
  }

 private:
  static constexpr float kUnseen = std::numeric_limits<float>::infinity();
  // The ground: a normal within 30 deg of the frame's z axis (REP-103: up in a robot's or a lidar's frame).
  static constexpr float kGroundNormalCosine = 0.866f;
  // Rays nearer parallel to the ground than this (17 deg) take it as 3.3 tau uncertain along them, not
  // more: at 0.1 (10 tau) the NCLT map search verified a window 240 m off, whose free space had refused it.
  static constexpr float kGrazingCosine = 0.3f;

  std::size_t index(int r, int c) const { return std::size_t(r) * cols_ + c; }

  bool cell(const Eigen::Vector3f& point, int& r, int& c, float& range) const {
    const Eigen::Vector3f d = point - viewpoint_;
    range = d.norm();
    if (!(range > 0.0f) || !std::isfinite(range)) return false;
    const double azimuth = std::atan2(d.y(), d.x());
    const double elevation = std::asin(std::clamp(double(d.z()) / range, -1.0, 1.0));
    c = std::clamp(int((azimuth + M_PI) / bin_), 0, cols_ - 1);
    r = std::clamp(int((elevation + M_PI / 2) / bin_), 0, rows_ - 1);
    return true;
  }

  Eigen::Vector3f viewpoint_;
  double bin_;
  int cols_ = 1, rows_ = 1;
  std::vector<float> boundary_;
};

double share(std::size_t part, std::size_t whole) { return whole > 0 ? double(part) / double(whole) : 0.0; }

// Fewest aligned keypoints the target must have seen for seen_on_surface to mean something, and fewest
// on its surfaces for surface_agreement.
constexpr std::size_t kFewestSeen = 10;

// Two surfaces lie along each other where their normals are within 30 deg (either orientation: a map's
// or a moved cloud's normals may face the other way).
const float kAlongCosine = float(std::cos(30.0 * M_PI / 180.0));

// A viewpoint whose nearest keypoint is more than this many cloud diagonals away is not where the cloud's
// sensor was but a frame origin somewhere else (a world or map frame): real scans are seen from close by
// (a lidar's nearest points are metres away in a scan 100 m across, an RGB-D camera's 0.5-1 m in a 3-5 m
// room, an object scanner's 0.3-1 m from a 10-30 cm object). From that far, any cloud looks like a depth
// map, so nothing else about it tells (doc/decisions/viewpoint-premise.md).
constexpr double kFarthestViewpoint = 10.0;

// Steps of the fine alignment at most: from a right pose it settles in 8 (median; 90 %: 17 on 3DMatch, 19 on
// NCLT keyframes); one still moving after 30 is sliding, which the verification weighs.
constexpr int kFineAlignmentSteps = 30;

Eigen::Vector3f centroid(const PointCloud& cloud) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : cloud) sum += p.getVector3fMap().cast<double>();
  return (sum / double(std::max<std::size_t>(1, cloud.size()))).cast<float>();
}

}  // namespace

// One cloud as its sensor saw it.
struct AlignmentJudge::View {
  PointCloud::ConstPtr points;
  pcl::PointCloud<pcl::Normal>::ConstPtr normals;  // per point, or null
  // The free-space and seen-on-surface evidence may rest on the viewpoint: one was given (a map's is not
  // finite: no single place saw it) and it is not more than kFarthestViewpoint diagonals away from the cloud.
  bool viewpoint_given = true;
  bool viewpoint_used = true;
  Eigen::Vector3f viewpoint;  // the given one, else the cloud's centroid (ranges for the reach only)
  float max_range = 0.0f;     // [m] of the farthest point from the viewpoint
  float min_range = 0.0f;     // [m] of the nearest
  CloudGrid near_grid;        // the points within tau of a placed point
  std::unique_ptr<RangeImage> image;

  View(const PointCloud::ConstPtr& cloud, const pcl::PointCloud<pcl::Normal>::ConstPtr& cloud_normals,
       const Eigen::Vector3f& from, double tau)
      : points(cloud),
        normals(cloud_normals && cloud_normals->size() == cloud->size() ? cloud_normals : nullptr),
        viewpoint_given(from.allFinite()),
        viewpoint(viewpoint_given ? from : centroid(*cloud)),
        near_grid(cloudGrid(*cloud, tau)) {
    std::vector<float> ranges;
    ranges.reserve(cloud->size());
    for (const auto& p : *cloud) ranges.push_back((p.getVector3fMap() - viewpoint).norm());
    max_range = *std::max_element(ranges.begin(), ranges.end());
    min_range = *std::min_element(ranges.begin(), ranges.end());
    std::nth_element(ranges.begin(), ranges.begin() + ranges.size() / 2, ranges.end());
    // Cells about tau wide at the median range: a few keypoints each on a surface facing the sensor.
    const double median_range = std::max(1e-3f, ranges[ranges.size() / 2]);
    image = std::make_unique<RangeImage>(*cloud, normals.get(), viewpoint,
                                         std::clamp(tau / median_range, 0.002, 0.1), tau);
  }

  // How `placed` (points put into this cloud's frame) agree with what this sensor saw.
  // `placed_normals`, when given, are the placed points' normals in this frame: those on a surface are
  // compared with its normal there (`with_normals`, `along`).
  struct Agreement {
    std::size_t points = 0, seen = 0, on_surface = 0, seen_on_surface = 0, in_free_space = 0;
    std::size_t with_normals = 0, along = 0;
  };
  Agreement compare(const std::vector<Eigen::Vector3f>& placed,
                    const std::vector<Eigen::Vector3f>* placed_normals, int threads) const {
    Agreement out;
    out.points = placed.size();
    const bool judge_normals = normals && placed_normals && placed_normals->size() == placed.size();
    std::size_t seen = 0, on = 0, seen_on = 0, front = 0, with_normals = 0, along = 0;
    const int n = int(placed.size());
#pragma omp parallel for schedule(static) reduction(+ : seen, on, seen_on, front, with_normals, along) \
    num_threads(threads)
    for (int i = 0; i < n; ++i) {
      pcl::PointXYZ query;
      query.getVector3fMap() = placed[i];
      int nearest = 0;
      float squared = 0.0f;
      const bool near = nearestWithin(near_grid, query, nearest, squared);
      float boundary = 0.0f, range = 0.0f;
      const bool looked = image->lookup(placed[i], boundary, range);
      on += near;
      seen += looked;
      seen_on += looked && near;
      front += looked && !near && range < boundary;
      if (near && judge_normals) {
        const float cosine = (*placed_normals)[i].dot((*normals)[nearest].getNormalVector3fMap());
        if (std::isfinite(cosine)) {
          ++with_normals;
          along += std::abs(cosine) >= kAlongCosine;
        }
      }
    }
    out.seen = seen;
    out.on_surface = on;
    out.seen_on_surface = seen_on;
    out.in_free_space = front;
    out.with_normals = with_normals;
    out.along = along;
    return out;
  }
};

AlignmentJudge::AlignmentJudge(const FeatureCorrespondences& f, double tau, int num_threads)
    : source_keypoints_(f.source_keypoints),
      target_keypoints_(f.target_keypoints),
      source_normals_(f.source_keypoint_normals),
      target_normals_(f.target_keypoint_normals),
      source_viewpoint_(f.source_viewpoint),
      target_viewpoint_(f.target_viewpoint),
      tau_(tau),
      threads_(num_threads > 0 ? num_threads : omp_get_max_threads()) {}

void AlignmentJudge::buildViews() const {
  std::call_once(built_, [this] {
    if (!source_keypoints_ || !target_keypoints_ || source_keypoints_->size() < 3 ||
        target_keypoints_->size() < 3)
      return;
    source_ = std::make_unique<View>(source_keypoints_, source_normals_, source_viewpoint_, tau_);
    target_ = std::make_unique<View>(target_keypoints_, target_normals_, target_viewpoint_, tau_);
    for (const auto& [view, role] : {std::pair<View*, const char*>{source_.get(), "source"},
                                     std::pair<View*, const char*>{target_.get(), "target"}}) {
      std::size_t finite = 0;
      view->viewpoint_used =
          view->viewpoint_given &&
          !(double(view->min_range) > kFarthestViewpoint * finiteDiagonal(*view->points, finite));
      if (view->viewpoint_given && !view->viewpoint_used)
        viewpoint_warnings_.push_back(viewpointNotUsed(role, *view));
    }
  });
}

std::vector<std::string> AlignmentJudge::warnings() const {
  buildViews();
  return viewpoint_warnings_;
}

AlignmentJudge::~AlignmentJudge() = default;

std::string AlignmentJudge::viewpointNotUsed(const char* role, const View& view) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(1) << "the " << role << "'s viewpoint was not used: ("
       << view.viewpoint.x() << ", " << view.viewpoint.y() << ", " << view.viewpoint.z()
       << ") m in its frame, its nearest point is " << view.min_range << " m away, more than "
       << kFarthestViewpoint << " times the cloud's own size (a world or map frame?); no free-space"
       << (std::string(role) == "target" ? " or seen-on-surface" : "") << " evidence from its view";
  return text.str();
}

std::optional<FineAlignment> AlignmentJudge::refine(const Eigen::Isometry3d& T) const {
  buildViews();
  if (!source_ || !target_ || !target_->normals) return std::nullopt;
  return alignPointToPlane(*source_->points, *target_->points, *target_->normals, target_->near_grid, T,
                           kFineAlignmentSteps, threads_);
}

VerificationSignals AlignmentJudge::judge(const Eigen::Isometry3d& T) const {
  buildViews();
  VerificationSignals signals;
  if (!source_ || !target_) return signals;
  const Eigen::Isometry3f forward = T.cast<float>();
  const Eigen::Isometry3f inverse = forward.inverse();
  std::vector<Eigen::Vector3f> source_in_target, target_in_source;
  source_in_target.reserve(source_->points->size());
  target_in_source.reserve(target_->points->size());
  for (const auto& p : *source_->points) source_in_target.push_back(forward * p.getVector3fMap());
  std::vector<Eigen::Vector3f> source_normals_in_target;
  if (source_->normals) {
    source_normals_in_target.reserve(source_->normals->size());
    for (const auto& n : *source_->normals)
      source_normals_in_target.push_back(forward.linear() * n.getNormalVector3fMap());
  }
  // Only what lies within the source sensor's reach can be judged by it: a map as the target would
  // otherwise cost a query per map point and dilute the shares with places the scan never saw.
  const float reach = source_->max_range + float(tau_);
  for (const auto& p : *target_->points) {
    const Eigen::Vector3f q = inverse * p.getVector3fMap();
    if ((q - source_->viewpoint).norm() <= reach) target_in_source.push_back(q);
  }
  const View::Agreement seen_by_target =
      target_->compare(source_in_target, source_->normals ? &source_normals_in_target : nullptr, threads_);
  const View::Agreement seen_by_source = source_->compare(target_in_source, nullptr, threads_);
  signals.aligned_overlap = share(seen_by_target.on_surface, seen_by_target.points);
  signals.seen_on_surface = target_->viewpoint_used && seen_by_target.seen >= kFewestSeen
                                ? share(seen_by_target.seen_on_surface, seen_by_target.seen)
                                : kNotMeasured;
  signals.surface_agreement = seen_by_target.with_normals >= kFewestSeen
                                  ? share(seen_by_target.along, seen_by_target.with_normals)
                                  : kNotMeasured;
  // Each view's free space counts only where its viewpoint does; with neither, the signal is not measured.
  if (target_->viewpoint_used || source_->viewpoint_used) {
    signals.free_space_violation =
        std::max(target_->viewpoint_used ? share(seen_by_target.in_free_space, seen_by_target.points) : 0.0,
                 source_->viewpoint_used ? share(seen_by_source.in_free_space, seen_by_source.points) : 0.0);
  }
  return signals;
}

}  // namespace mac_registration
