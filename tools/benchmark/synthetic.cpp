#include "synthetic.hpp"

#include <algorithm>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace mac_registration {

TriangleMesh readAsciiPlyMesh(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open mesh '" + path + "'");
  std::string line;
  long vertices = -1, faces = 0;
  int vertex_properties = 0;
  bool in_vertex = false;
  while (std::getline(in, line) && line.rfind("end_header", 0) != 0) {
    std::istringstream words(line);
    std::string word, kind;
    words >> word;
    if (word == "format" && (words >> kind) && kind != "ascii")
      throw std::runtime_error(path + ": not an ASCII PLY");
    if (word == "element") {
      words >> kind;
      in_vertex = kind == "vertex";
      if (kind == "vertex") words >> vertices;
      if (kind == "face") words >> faces;
    }
    if (word == "property" && in_vertex) ++vertex_properties;
  }
  if (vertices <= 0 || vertex_properties < 3) throw std::runtime_error(path + ": no vertices with x y z");
  TriangleMesh mesh;
  for (long v = 0; v < vertices && std::getline(in, line); ++v) {
    std::istringstream values(line);
    Eigen::Vector3d p;
    if (!(values >> p.x() >> p.y() >> p.z())) throw std::runtime_error(path + ": bad vertex line");
    mesh.vertices.push_back(p);
  }
  for (long f = 0; f < faces && std::getline(in, line); ++f) {
    std::istringstream values(line);
    int count;
    Eigen::Vector3i face;
    if (!(values >> count >> face.x() >> face.y() >> face.z()) || count != 3) continue;
    if ((face.array() >= 0).all() && (face.array() < int(mesh.vertices.size())).all())
      mesh.faces.push_back(face);
  }
  if (mesh.faces.empty()) throw std::runtime_error(path + ": no triangles");
  return mesh;
}

SyntheticProblem makeSyntheticProblem(const TriangleMesh& mesh, const SyntheticSpec& spec) {
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);

  Eigen::AlignedBox3d box;
  for (const auto& v : mesh.vertices) box.extend(v);
  const double scale = spec.object_size / box.diagonal().norm();
  const Eigen::Vector3d centre = box.center();

  std::vector<double> cumulative_area;
  double area = 0.0;
  for (const auto& f : mesh.faces) {
    area += 0.5 * (mesh.vertices[f.y()] - mesh.vertices[f.x()])
                      .cross(mesh.vertices[f.z()] - mesh.vertices[f.x()])
                      .norm();
    cumulative_area.push_back(area);
  }
  const auto surfacePoint = [&]() {
    const auto face = std::lower_bound(cumulative_area.begin(), cumulative_area.end(), unit(rng) * area);
    const auto& f = mesh.faces[std::min<std::size_t>(face - cumulative_area.begin(), mesh.faces.size() - 1)];
    double u = unit(rng), v = unit(rng);
    if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
    const Eigen::Vector3d& a = mesh.vertices[f.x()];
    return Eigen::Vector3d(scale *
                           (a + u * (mesh.vertices[f.y()] - a) + v * (mesh.vertices[f.z()] - a) - centre));
  };

  SyntheticProblem problem;
  const Eigen::Quaterniond rotation =
      Eigen::Quaterniond(gauss(rng), gauss(rng), gauss(rng), gauss(rng)).normalized();
  problem.T_target_source.linear() = rotation.toRotationMatrix();
  problem.T_target_source.translation() =
      spec.object_size * Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);

  const int n = spec.correspondences;
  const int inliers = static_cast<int>(std::lround(spec.inlier_ratio * n));
  problem.is_inlier.assign(n, 0);
  std::fill(problem.is_inlier.begin(), problem.is_inlier.begin() + inliers, 1);
  std::shuffle(problem.is_inlier.begin(), problem.is_inlier.end(), rng);

  Eigen::AlignedBox3d target_box;
  for (const auto& v : mesh.vertices)
    target_box.extend(problem.T_target_source * Eigen::Vector3d(scale * (v - centre)));
  auto& c = problem.correspondences;
  c.source_points.resize(3, n);
  c.target_points.resize(3, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d s = surfacePoint();
    c.source_points.col(i) = s;
    if (problem.is_inlier[i]) {
      c.target_points.col(i) = problem.T_target_source * s +
                               spec.noise_sigma * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
    } else {
      const Eigen::Vector3d r(unit(rng), unit(rng), unit(rng));
      c.target_points.col(i) = target_box.min() + r.cwiseProduct(target_box.sizes());
    }
  }
  return problem;
}

}  // namespace mac_registration
