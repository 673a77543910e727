#include "mac_registration/features/cloud_io.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <new>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "cloud_file_parsing.hpp"
#include "mac_registration/features/cloud_filtering.hpp"

namespace mac_registration {
namespace {

std::string lowerCaseExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

// KITTI Velodyne scans: a bare array of float32 (x, y, z, reflectance), little-endian, no header.
cloud_file::FileCloud loadKittiBin(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open '" + path + "' for reading");
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  constexpr std::size_t kRecord = 4 * sizeof(float);
  if (bytes.size() % kRecord != 0) {
    throw std::runtime_error("'" + path + "' is not a KITTI .bin cloud: its " + std::to_string(bytes.size()) +
                             " bytes are not a whole number of 16-byte (x y z intensity) records");
  }
  cloud_file::FileCloud cloud;
  cloud.points.resize(bytes.size() / kRecord);
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    float record[4];
    std::memcpy(record, bytes.data() + i * kRecord, kRecord);
    cloud.points[i] = Eigen::Vector3f(record[0], record[1], record[2]).cast<double>();
  }
  cloud.width = std::uint32_t(cloud.points.size());
  return cloud;
}

// A .pcd or .ply file, with the readers' errors naming the file.
cloud_file::FileCloud readCloudFile(const std::string& path, const std::string& extension,
                                    std::vector<std::string>& warnings) {
  try {
    return extension == ".pcd" ? cloud_file::readPcdFile(path, warnings) : cloud_file::readPlyFile(path);
  } catch (const cloud_file::Malformed& e) {
    throw std::runtime_error("cannot read cloud '" + path + "': not a valid " + extension + " file (" +
                             e.what() + ")");
  } catch (const std::bad_alloc&) {
    // The readers allocate no more than a small multiple of the file's size: this is a huge file.
    throw std::runtime_error("cannot read cloud '" + path + "': out of memory reading it");
  }
}

// The points of a file of any of the three formats, checked to be some.
cloud_file::FileCloud readAnyCloudFile(const std::string& path, std::vector<std::string>* warnings) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw std::runtime_error("cannot read cloud '" + path + "': no such file");
  const std::string extension = lowerCaseExtension(path);
  cloud_file::FileCloud file;
  if (extension == ".bin") {
    file = loadKittiBin(path);
  } else if (extension == ".pcd" || extension == ".ply") {
    std::vector<std::string> faults;
    file = readCloudFile(path, extension, faults);
    for (const auto& fault : faults) {
      if (warnings) warnings->push_back("cloud '" + path + "': " + fault);
    }
  } else {
    throw std::runtime_error("cannot read cloud '" + path + "': unknown extension '" + extension +
                             "' (expected .pcd, .ply or .bin)");
  }
  if (file.points.empty()) throw std::runtime_error("cloud '" + path + "' has no points");
  return file;
}

// Where a cloud's coordinates are measured from: the file's origin (loadCloud) or a local one.
enum class Frame { kFile, kLocal };

LocalCloud readCloud(const std::string& path, std::vector<std::string>* warnings, Frame frame) {
  const cloud_file::FileCloud file = readAnyCloudFile(path, warnings);
  LocalCloud local;
  try {
    if (frame == Frame::kLocal) local.origin = localOrigin(file.points);
    local.cloud = cloud_file::toPointCloud(file, local.origin);
  } catch (const std::bad_alloc&) {
    throw std::runtime_error("cannot read cloud '" + path + "': out of memory reading it");
  }
  const std::string bound = coordinateBoundProblem(*local.cloud);
  if (!bound.empty()) throw std::runtime_error("cannot use cloud '" + path + "': " + bound);
  return local;
}

}  // namespace

// The median by nth_element on a copy of one axis at a time: 8 bytes a point more, for a moment.
Eigen::Vector3d localOrigin(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::vector<double> values;
  values.reserve(points.size());
  for (int axis = 0; axis < 3; ++axis) {
    values.clear();
    bool within = true;
    for (const auto& p : points) {
      if (!p.allFinite()) continue;  // the front end drops the point
      values.push_back(p[axis]);
      within = within && std::abs(p[axis]) <= kLocalFrameBound;
    }
    if (within) continue;  // no finite point, too
    const auto median = values.begin() + std::ptrdiff_t(values.size() / 2);
    std::nth_element(values.begin(), median, values.end());
    origin[axis] = std::round(*median);
  }
  return origin;
}

PointCloud::Ptr loadCloud(const std::string& path, std::vector<std::string>* warnings) {
  return readCloud(path, warnings, Frame::kFile).cloud;
}

LocalCloud loadLocalCloud(const std::string& path, std::vector<std::string>* warnings) {
  return readCloud(path, warnings, Frame::kLocal);
}

}  // namespace mac_registration
