#include "mac_registration/core/text_io.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace mac_registration {
namespace {

std::ifstream openForReading(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "' for reading");
  return in;
}

}  // namespace

CorrespondenceSet readCorrespondencesFile(const std::string& path) {
  std::ifstream in = openForReading(path);
  std::vector<double> values;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    double v[6];
    std::string extra;
    for (double& x : v) {
      // Parse as text so that "nan" and "inf" are kept (the core drops and counts them).
      std::string token;
      if (!(fields >> token)) {
        throw std::runtime_error(path + ":" + std::to_string(number) +
                                 ": expected 6 numbers (xs ys zs xt yt zt)");
      }
      try {
        std::size_t used = 0;
        x = std::stod(token, &used);
        if (used != token.size()) throw std::invalid_argument(token);
      } catch (const std::exception&) {
        throw std::runtime_error(path + ":" + std::to_string(number) + ": '" + token + "' is not a number");
      }
    }
    if (fields >> extra) {
      throw std::runtime_error(path + ":" + std::to_string(number) + ": more than 6 values on the line");
    }
    values.insert(values.end(), v, v + 6);
  }
  const auto n = static_cast<Eigen::Index>(values.size() / 6);
  CorrespondenceSet c;
  c.source_points.resize(3, n);
  c.target_points.resize(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    c.source_points.col(i) << values[6 * i], values[6 * i + 1], values[6 * i + 2];
    c.target_points.col(i) << values[6 * i + 3], values[6 * i + 4], values[6 * i + 5];
  }
  return c;
}

Eigen::Isometry3d readTransformFile(const std::string& path) {
  std::ifstream in = openForReading(path);
  std::vector<double> values;
  double v;
  while (values.size() < 16 && in >> v) values.push_back(v);
  if (values.size() < 12) {
    throw std::runtime_error("'" + path + "' holds " + std::to_string(values.size()) +
                             " numbers; a transform needs 12 or 16 (row-major 4x4)");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int col = 0; col < 4; ++col) T.matrix()(r, col) = values[4 * r + col];
  }
  return T;
}

std::string formatTransform(const Eigen::Isometry3d& T) {
  std::ostringstream out;
  out << std::setprecision(10) << std::fixed;
  for (int r = 0; r < 4; ++r) {
    for (int col = 0; col < 4; ++col) out << (col ? " " : "") << std::setw(14) << T.matrix()(r, col);
    out << "\n";
  }
  return out.str();
}

void writeTransformFile(const std::string& path, const Eigen::Isometry3d& T) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot open '" + path + "' for writing");
  out << formatTransform(T);
  if (!out) throw std::runtime_error("failed writing '" + path + "'");
}

}  // namespace mac_registration
