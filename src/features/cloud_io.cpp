#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "mac_registration/features/cloud_registration.hpp"

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

// The header lines of a text-headed format, up to and including the line whose first word is `last`
// (at most 200 lines: a header is short; a binary file without one must not be read whole).
std::vector<std::vector<std::string>> headerLines(const std::string& path, const std::string& last) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open '" + path + "' for reading");
  std::vector<std::vector<std::string>> lines;
  std::string line;
  for (int n = 0; n < 200 && std::getline(in, line); ++n) {
    std::istringstream words(line);
    std::vector<std::string> tokens;
    for (std::string word; words >> word;) tokens.push_back(word);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    lines.push_back(tokens);
    if (tokens[0] == last) return lines;
  }
  return {};  // no terminating line: not this format
}

bool hasXyz(const std::vector<std::string>& names) {
  for (const char* axis : {"x", "y", "z"}) {
    if (std::find(names.begin(), names.end(), axis) == names.end()) return false;
  }
  return true;
}

// PCL's readers trust the header: PCL 1.13 dereferences a null pointer on a .pcd without one, and fills
// a missing x, y or z with zeros. Checking the header first turns both into an error naming the file.
void checkPcdHeader(const std::string& path) {
  const auto lines = headerLines(path, "DATA");
  const auto invalid = [&](const std::string& why) {
    return std::runtime_error("cannot read cloud '" + path + "': not a valid .pcd file (" + why + ")");
  };
  if (lines.empty()) throw invalid("no header ending in a DATA line");
  bool xyz = false;
  for (const auto& tokens : lines) {
    if (tokens[0] == "FIELDS") xyz = hasXyz(tokens);
  }
  if (!xyz) throw invalid("no FIELDS x y z");
}

void checkPlyHeader(const std::string& path) {
  const auto lines = headerLines(path, "end_header");
  const auto invalid = [&](const std::string& why) {
    return std::runtime_error("cannot read cloud '" + path + "': not a valid .ply file (" + why + ")");
  };
  if (lines.empty() || lines.front() != std::vector<std::string>{"ply"})
    throw invalid("no header from 'ply' to 'end_header'");
  std::vector<std::string> vertex_properties;
  bool in_vertex = false;
  for (const auto& tokens : lines) {
    if (tokens[0] == "element") in_vertex = tokens.size() > 1 && tokens[1] == "vertex";
    if (in_vertex && tokens[0] == "property" && tokens.size() >= 3)
      vertex_properties.push_back(tokens.back());
  }
  if (!hasXyz(vertex_properties)) throw invalid("no vertex element with x, y and z");
}

}  // namespace

PointCloud::Ptr loadCloud(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw std::runtime_error("cannot read cloud '" + path + "': no such file");
  const std::string extension = lowerCaseExtension(path);
  PointCloud::Ptr cloud;
  if (extension == ".bin") {
    cloud = loadKittiBin(path);
  } else if (extension == ".pcd" || extension == ".ply") {
    if (extension == ".pcd")
      checkPcdHeader(path);
    else
      checkPlyHeader(path);
    cloud = pcl::make_shared<PointCloud>();
    const int status =
        extension == ".pcd" ? pcl::io::loadPCDFile(path, *cloud) : pcl::io::loadPLYFile(path, *cloud);
    if (status < 0)
      throw std::runtime_error("cannot read cloud '" + path + "': not a valid " + extension + " file");
  } else {
    throw std::runtime_error("cannot read cloud '" + path + "': unknown extension '" + extension +
                             "' (expected .pcd, .ply or .bin)");
  }
  if (cloud->empty()) throw std::runtime_error("cloud '" + path + "' has no points");
  return cloud;
}

}  // namespace mac_registration
