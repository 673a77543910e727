#include "mac_registration/features/cloud_io.hpp"

#include <algorithm>
#include <cctype>
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
PointCloud::Ptr loadKittiBin(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open '" + path + "' for reading");
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  constexpr std::size_t kRecord = 4 * sizeof(float);
  if (bytes.size() % kRecord != 0) {
    throw std::runtime_error("'" + path + "' is not a KITTI .bin cloud: its " + std::to_string(bytes.size()) +
                             " bytes are not a whole number of 16-byte (x y z intensity) records");
  }
  auto cloud = pcl::make_shared<PointCloud>();
  cloud->resize(bytes.size() / kRecord);
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    float record[4];
    std::memcpy(record, bytes.data() + i * kRecord, kRecord);
    (*cloud)[i] = pcl::PointXYZ(record[0], record[1], record[2]);
  }
  return cloud;
}

// A .pcd or .ply file, with the readers' errors naming the file.
PointCloud::Ptr readCloudFile(const std::string& path, const std::string& extension,
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

}  // namespace

PointCloud::Ptr loadCloud(const std::string& path, std::vector<std::string>* warnings) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw std::runtime_error("cannot read cloud '" + path + "': no such file");
  const std::string extension = lowerCaseExtension(path);
  PointCloud::Ptr cloud;
  if (extension == ".bin") {
    cloud = loadKittiBin(path);
  } else if (extension == ".pcd" || extension == ".ply") {
    std::vector<std::string> faults;
    cloud = readCloudFile(path, extension, faults);
    for (const auto& fault : faults) {
      if (warnings) warnings->push_back("cloud '" + path + "': " + fault);
    }
  } else {
    throw std::runtime_error("cannot read cloud '" + path + "': unknown extension '" + extension +
                             "' (expected .pcd, .ply or .bin)");
  }
  if (cloud->empty()) throw std::runtime_error("cloud '" + path + "' has no points");
  const std::string bound = coordinateBoundProblem(*cloud);
  if (!bound.empty()) throw std::runtime_error("cannot use cloud '" + path + "': " + bound);
  return cloud;
}

}  // namespace mac_registration
