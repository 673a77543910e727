#include "cloud_file_parsing.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <system_error>

namespace mac_registration {
namespace cloud_file {

LineReader::LineReader(const std::string& path) : in_(path, std::ios::binary) {
  if (!in_) throw std::runtime_error("cannot open '" + path + "' for reading");
}

bool LineReader::next(std::vector<std::string>& words) {
  constexpr std::size_t kMaxLine = 1 << 16;
  std::string line;
  int c = 0;
  while ((c = in_.get()) != EOF && c != '\n') {
    if (line.size() == kMaxLine)
      throw Malformed("line " + std::to_string(line_ + 1) + " is longer than " + std::to_string(kMaxLine) +
                      " bytes");
    line.push_back(static_cast<char>(c));
  }
  if (c == EOF && line.empty()) return false;
  ++line_;
  offset_ += line.size() + (c == '\n' ? 1 : 0);
  words.clear();
  std::istringstream stream(line);
  for (std::string word; stream >> word;) words.push_back(word);
  return true;
}

std::string fileText(const std::string& text) {
  const auto isPrintable = [](unsigned char c) { return c >= 0x20 && c < 0x7f; };
  const auto unprintable =
      std::size_t(std::count_if(text.begin(), text.end(), [&](char c) { return !isPrintable(c); }));
  if (unprintable * 4 > text.size())
    return "(" + std::to_string(text.size()) + (text.size() == 1 ? " byte" : " bytes") + " of binary data)";
  constexpr std::size_t kMaxChars = 60;
  std::string out = "'";
  for (const char c : text) {
    if (out.size() > kMaxChars) {
      out += "...";
      break;
    }
    if (isPrintable(c)) {
      out += c;
    } else {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02X", static_cast<unsigned char>(c));
      out += escaped;
    }
  }
  return out + "'";
}

std::string joinedWords(const std::vector<std::string>& words) {
  std::string text;
  for (const auto& w : words) text += (text.empty() ? "" : " ") + w;
  return fileText(text);
}

bool parseCount(const std::string& word, std::uint64_t max, std::uint64_t& value) {
  if (word.empty() || word.size() > 19 ||
      !std::all_of(word.begin(), word.end(), [](unsigned char c) { return std::isdigit(c); }))
    return false;
  value = std::stoull(word);
  return value <= max;
}

bool parseNumber(const std::string& word, double& value) {
  char* end = nullptr;
  value = std::strtod(word.c_str(), &end);
  return !word.empty() && end == word.c_str() + word.size();
}

std::uint64_t checkedProduct(std::uint64_t a, std::uint64_t b, const std::string& what) {
  std::uint64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product)) throw Malformed(what + " overflows 64 bits");
  return product;
}

std::uint64_t checkedSum(std::uint64_t a, std::uint64_t b, const std::string& what) {
  std::uint64_t sum = 0;
  if (__builtin_add_overflow(a, b, &sum)) throw Malformed(what + " overflows 64 bits");
  return sum;
}

std::uint64_t fileSize(const std::string& path) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (error) throw std::runtime_error("cannot read cloud '" + path + "': " + error.message());
  return size;
}

double decodeScalar(const char* bytes, ScalarType type, bool little_endian) {
  std::uint64_t bits = 0;
  for (unsigned i = 0; i < type.bytes; ++i) {
    const auto byte = static_cast<unsigned char>(bytes[little_endian ? type.bytes - 1 - i : i]);
    bits = (bits << 8) | byte;
  }
  switch (type.kind) {
    case ScalarType::kUnsigned:
      return double(bits);
    case ScalarType::kSigned:
      if (type.bytes < 8 && (bits >> (8 * type.bytes - 1)) != 0)
        bits |= ~std::uint64_t(0) << (8 * type.bytes);
      return double(static_cast<std::int64_t>(bits));
    case ScalarType::kFloat:
      break;
  }
  if (type.bytes == 4) {
    const auto narrow = static_cast<std::uint32_t>(bits);
    float value = 0.0f;
    std::memcpy(&value, &narrow, sizeof value);
    return value;
  }
  double value = 0.0;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

float toCoordinate(double value) {
  constexpr float kLargest = std::numeric_limits<float>::max();
  if (!std::isfinite(value)) return static_cast<float>(value);
  return static_cast<float>(std::clamp(value, double(-kLargest), double(kLargest)));
}

PointCloud::Ptr toPointCloud(const FileCloud& file, const Eigen::Vector3d& origin) {
  // A finite coordinate stays finite even if the subtraction overflows (an origin taken from garbage).
  const auto local = [](double value, double origin) {
    constexpr double kLargest = std::numeric_limits<double>::max();
    return toCoordinate(std::isfinite(value) ? std::clamp(value - origin, -kLargest, kLargest) : value);
  };
  auto cloud = pcl::make_shared<PointCloud>();
  cloud->resize(file.points.size());
  bool all_finite = true;  // is_dense as PCL means it
  for (std::size_t i = 0; i < file.points.size(); ++i) {
    const Eigen::Vector3d& p = file.points[i];
    pcl::PointXYZ& q = (*cloud)[i];
    q = pcl::PointXYZ(local(p.x(), origin.x()), local(p.y(), origin.y()), local(p.z(), origin.z()));
    all_finite = all_finite && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
  }
  cloud->width = file.width;
  cloud->height = file.height;
  cloud->is_dense = all_finite;
  const Eigen::Vector3d viewpoint = file.viewpoint - origin;
  cloud->sensor_origin_ =
      Eigen::Vector4f(float(viewpoint.x()), float(viewpoint.y()), float(viewpoint.z()), 0.0f);
  cloud->sensor_orientation_ = file.orientation;
  return cloud;
}

}  // namespace cloud_file
}  // namespace mac_registration
