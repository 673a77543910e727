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

bool allFinite(const PointCloud& cloud) {
  return std::all_of(cloud.begin(), cloud.end(), [](const pcl::PointXYZ& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  });
}

}  // namespace cloud_file
}  // namespace mac_registration
