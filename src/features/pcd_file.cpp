// PCD files (PCL's format): the header is checked whole, then x, y and z are read from the body by the
// header's layout. PCL's own reader trusts the header (an unknown line or a missing field list made PCL
// 1.13 dereference a null pointer, a huge WIDTH made it allocate without bound, a short binary body was
// read past its end) and cannot convert a double or integer x into PointXYZ (every point became the
// origin), so it is not used.
#include <pcl/io/lzf.h>

#include <algorithm>
#include <set>

#include "cloud_file_parsing.hpp"

namespace mac_registration {
namespace cloud_file {
namespace {

struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<std::uint64_t> sizes, counts;
  std::vector<ScalarType::Kind> kinds;
  std::uint64_t width = 0, height = 1, points = 0;
  std::string data;
  std::uint64_t body_offset = 0;
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();

  std::uint64_t fieldBytes(std::size_t i) const { return sizes[i] * counts[i]; }
  std::uint64_t pointBytes() const {  // sizes <= 8, counts <= 2^20, fields < 2^16: no overflow
    std::uint64_t bytes = 0;
    for (std::size_t i = 0; i < fields.size(); ++i) bytes += fieldBytes(i);
    return bytes;
  }
  std::uint64_t valuesPerPoint() const {
    std::uint64_t values = 0;
    for (const auto c : counts) values += c;
    return values;
  }
};

// Where x, y and z of a point lie: their field's byte offset in a point's record (binary; in
// binary_compressed the field's block starts at POINTS times it), their index among an ascii line's values,
// and how they are stored.
struct CoordinateLayout {
  std::uint64_t byte_offset[3] = {};
  std::uint64_t value_index[3] = {};
  ScalarType type[3];
};

ScalarType::Kind pcdKind(const std::string& type) {
  if (type == "F") return ScalarType::kFloat;
  if (type == "I") return ScalarType::kSigned;
  if (type == "U") return ScalarType::kUnsigned;
  throw Malformed("TYPE " + fileText(type) + " is not F, I or U");
}

void parsePcdLine(const std::vector<std::string>& words, PcdHeader& h) {
  const std::string& key = words[0];
  const std::vector<std::string> values(words.begin() + 1, words.end());
  const auto expectOne = [&] {
    if (values.size() != 1) throw Malformed(key + " needs one value, got " + joinedWords(values));
  };
  const auto count = [&](const std::string& word, std::uint64_t max) {
    std::uint64_t n = 0;
    if (!parseCount(word, max, n))
      throw Malformed(key + " value " + fileText(word) + " is not a whole number from 0 to " +
                      std::to_string(max));
    return n;
  };
  if (key == "VERSION") {
    expectOne();
  } else if (key == "FIELDS") {
    if (values.empty()) throw Malformed("FIELDS names no field");
    std::set<std::string> seen;
    for (const auto& name : values) {
      // PCL writes padding as fields named "_", possibly several.
      if (name != "_" && !seen.insert(name).second) throw Malformed("two fields named " + fileText(name));
    }
    h.fields = values;
  } else if (key == "SIZE") {
    for (const auto& v : values) {
      const std::uint64_t size = count(v, 8);
      if (size != 1 && size != 2 && size != 4 && size != 8)
        throw Malformed("SIZE " + v + " is not 1, 2, 4 or 8 bytes");  // v is digits: count() checked it
      h.sizes.push_back(size);
    }
  } else if (key == "TYPE") {
    for (const auto& v : values) h.kinds.push_back(pcdKind(v));
  } else if (key == "COUNT") {
    for (const auto& v : values) {
      const std::uint64_t n = count(v, 1 << 20);
      if (n == 0) throw Malformed("COUNT 0 (every field holds at least one value)");
      h.counts.push_back(n);
    }
  } else if (key == "WIDTH") {
    expectOne();
    h.width = count(values[0], kMaxPoints);
  } else if (key == "HEIGHT") {
    expectOne();
    h.height = count(values[0], kMaxPoints);
  } else if (key == "VIEWPOINT") {
    double v[7] = {};
    bool numbers = values.size() == 7;
    for (std::size_t i = 0; numbers && i < 7; ++i) numbers = parseNumber(values[i], v[i]);
    if (!numbers) throw Malformed("VIEWPOINT needs 7 numbers (tx ty tz qw qx qy qz)");
    h.viewpoint = Eigen::Vector3d(v[0], v[1], v[2]);
    h.orientation = Eigen::Quaternionf(float(v[3]), float(v[4]), float(v[5]), float(v[6]));
  } else if (key == "POINTS") {
    expectOne();
    h.points = count(values[0], kMaxPoints);
  } else if (key == "DATA") {
    expectOne();
    if (values[0] != "ascii" && values[0] != "binary" && values[0] != "binary_compressed")
      throw Malformed("DATA " + fileText(values[0]) + " is not ascii, binary or binary_compressed");
    h.data = values[0];
  }
}

// The grid of the points: WIDTH x HEIGHT, which must be POINTS. Files of PCD v0.5 name only POINTS (an
// unorganised cloud of them); SLAM pipelines write WIDTH 0 HEIGHT 0 with POINTS N, which Open3D reads as
// N unorganised points and so does this, with a warning, because the header is faulty.
void checkPcdGrid(const std::set<std::string>& seen, PcdHeader& h, std::vector<std::string>& warnings) {
  if (!seen.count("WIDTH")) {
    if (seen.count("HEIGHT")) throw Malformed("HEIGHT but no WIDTH line in the header");
    if (!seen.count("POINTS")) throw Malformed("no WIDTH or POINTS line in the header");
    h.width = h.points;
  }
  const std::uint64_t grid = h.width * h.height;  // both <= 2^31: no overflow
  if (!seen.count("POINTS")) h.points = grid;
  if (grid == 0 && h.points > 0) {
    warnings.push_back("its header says WIDTH " + std::to_string(h.width) + " HEIGHT " +
                       std::to_string(h.height) + " but POINTS " + std::to_string(h.points) +
                       " (WIDTH x HEIGHT should be POINTS); read as " + std::to_string(h.points) +
                       " unorganised points");
    h.width = h.points;
    h.height = 1;
  } else if (grid != h.points) {
    throw Malformed("WIDTH x HEIGHT = " + std::to_string(h.width) + " x " + std::to_string(h.height) +
                    " is not POINTS " + std::to_string(h.points));
  }
}

PcdHeader readPcdHeader(LineReader& reader, std::vector<std::string>& warnings) {
  // COLUMNS: an older name of FIELDS, which PCL still reads.
  static const std::set<std::string> kKeywords = {"VERSION", "FIELDS", "COLUMNS",   "SIZE",   "TYPE", "COUNT",
                                                  "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
  PcdHeader h;
  std::set<std::string> seen;
  for (std::vector<std::string> words; h.data.empty();) {
    if (!reader.next(words)) throw Malformed("no header ending in a DATA line");
    if (words.empty() || words[0][0] == '#') continue;
    if (!kKeywords.count(words[0])) {
      throw Malformed(
          "unknown header line " + std::to_string(reader.line()) + " " + joinedWords(words) +
          "; a header has only VERSION FIELDS SIZE TYPE COUNT WIDTH HEIGHT VIEWPOINT POINTS DATA");
    }
    if (words[0] == "COLUMNS") words[0] = "FIELDS";
    if (!seen.insert(words[0]).second) throw Malformed(words[0] + " appears twice in the header");
    parsePcdLine(words, h);
  }
  h.body_offset = reader.offset();
  if (!seen.count("FIELDS")) throw Malformed("no FIELDS line in the header");
  // Older headers have neither; PCL reads every field of them as one float32, and so does this.
  if (!seen.count("SIZE") && !seen.count("TYPE")) {
    h.sizes.assign(h.fields.size(), 4);
    h.kinds.assign(h.fields.size(), ScalarType::kFloat);
  } else {
    for (const char* required : {"SIZE", "TYPE"}) {
      if (!seen.count(required)) throw Malformed(std::string("no ") + required + " line in the header");
    }
  }
  checkPcdGrid(seen, h, warnings);
  return h;
}

// Checks the field lists against each other and finds x, y and z. Coordinates of any numeric type are
// read (Open3D writes doubles; integer coordinates are as legal in the format): one value each.
CoordinateLayout coordinateLayout(PcdHeader& h) {
  const std::size_t n = h.fields.size();
  if (h.counts.empty()) h.counts.assign(n, 1);  // COUNT is optional
  if (h.sizes.size() != n || h.kinds.size() != n || h.counts.size() != n) {
    throw Malformed(std::to_string(n) + " FIELDS but " + std::to_string(h.sizes.size()) + " SIZE, " +
                    std::to_string(h.kinds.size()) + " TYPE and " + std::to_string(h.counts.size()) +
                    " COUNT values");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (h.kinds[i] == ScalarType::kFloat && h.sizes[i] != 4 && h.sizes[i] != 8)
      throw Malformed("field " + fileText(h.fields[i]) + " is F of " + std::to_string(h.sizes[i]) + " bytes");
  }
  CoordinateLayout layout;
  for (int axis = 0; axis < 3; ++axis) {
    const std::string name(1, "xyz"[axis]);
    const auto at = std::find(h.fields.begin(), h.fields.end(), name);
    if (at == h.fields.end()) throw Malformed("no FIELDS x y z");
    const auto i = std::size_t(at - h.fields.begin());
    if (h.counts[i] != 1)
      throw Malformed("field '" + name + "' holds COUNT " + std::to_string(h.counts[i]) +
                      " values, not one coordinate");
    for (std::size_t before = 0; before < i; ++before) {
      layout.byte_offset[axis] += h.fieldBytes(before);
      layout.value_index[axis] += h.counts[before];
    }
    layout.type[axis] = {h.kinds[i], unsigned(h.sizes[i])};
  }
  return layout;
}

// One value a line and one line a point, each a number: PCL's reader fills what a short line lacks and
// only warns "possibly malformed", which would read a damaged file as a different cloud.
void readAsciiBody(LineReader& reader, const PcdHeader& h, const CoordinateLayout& layout,
                   std::uint64_t available, std::vector<Eigen::Vector3d>& points) {
  const std::uint64_t values = h.valuesPerPoint();
  points.reserve(std::min(h.points, available / (2 * values)));  // a garbage POINTS must not allocate
  double point[3] = {};
  for (std::vector<std::string> words; reader.next(words);) {
    if (words.empty()) continue;
    if (points.size() == h.points)
      throw Malformed("more data lines than its " + std::to_string(h.points) + " POINTS (line " +
                      std::to_string(reader.line()) + ")");
    if (words.size() != values) {
      throw Malformed("line " + std::to_string(reader.line()) + " holds " + std::to_string(words.size()) +
                      " values, not " + std::to_string(values));
    }
    for (std::size_t k = 0; k < words.size(); ++k) {
      double value = 0.0;
      if (!parseNumber(words[k], value))
        throw Malformed("line " + std::to_string(reader.line()) + ": " + fileText(words[k]) +
                        " is not a number");
      for (int axis = 0; axis < 3; ++axis) {
        if (k == layout.value_index[axis]) point[axis] = value;
      }
    }
    points.emplace_back(point[0], point[1], point[2]);
  }
  if (points.size() < h.points) {
    throw Malformed("POINTS " + std::to_string(h.points) + " but " + std::to_string(points.size()) +
                    " data lines (truncated?)");
  }
}

// The points of a decoded body in which the value of `axis` for point k lies at
// first[axis] + k * stride[axis]. PCL writes the bytes of this machine: little-endian.
void decodePoints(const std::vector<char>& body, const std::uint64_t first[3], const std::uint64_t stride[3],
                  const CoordinateLayout& layout, std::uint64_t count, std::vector<Eigen::Vector3d>& points) {
  points.resize(count);
  for (std::uint64_t k = 0; k < count; ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      const char* at = body.data() + first[axis] + k * stride[axis];
      points[k][axis] = decodeScalar(at, layout.type[axis], true);
    }
  }
}

// POINTS records of the fields in their order.
void readBinaryBody(std::istream& in, const PcdHeader& h, const CoordinateLayout& layout,
                    std::uint64_t available, std::vector<Eigen::Vector3d>& points) {
  const std::uint64_t needed = checkedProduct(h.points, h.pointBytes(), "POINTS x point size");
  if (available < needed) {
    throw Malformed(std::to_string(h.points) + " points of " + std::to_string(h.pointBytes()) +
                    " bytes need " + std::to_string(needed) + " bytes of binary data, the file holds " +
                    std::to_string(available) + " (truncated?)");
  }
  std::vector<char> body(needed);
  if (!in.read(body.data(), std::streamsize(needed))) throw Malformed("its binary data cannot be read");
  const std::uint64_t stride[3] = {h.pointBytes(), h.pointBytes(), h.pointBytes()};
  decodePoints(body, layout.byte_offset, stride, layout, h.points, points);
}

// Two uint32 (the compressed and the unpacked size), then an LZF stream that unpacks to the fields one
// after the other, each field's values for every point together.
void readCompressedBody(std::istream& in, const PcdHeader& h, const CoordinateLayout& layout,
                        std::uint64_t available, std::vector<Eigen::Vector3d>& points) {
  const std::uint64_t needed = checkedProduct(h.points, h.pointBytes(), "POINTS x point size");
  char size_words[8];
  if (available < sizeof size_words || !in.read(size_words, sizeof size_words))
    throw Malformed("binary_compressed data without its two size words");
  constexpr ScalarType kUint32{ScalarType::kUnsigned, 4};
  const auto compressed_size = std::uint64_t(decodeScalar(size_words, kUint32, true));
  const auto unpacked_size = std::uint64_t(decodeScalar(size_words + 4, kUint32, true));
  if (unpacked_size != needed) {
    throw Malformed("binary_compressed data unpacks to " + std::to_string(unpacked_size) + " bytes, but " +
                    std::to_string(h.points) + " points of " + std::to_string(h.pointBytes()) +
                    " bytes are " + std::to_string(needed));
  }
  if (compressed_size + sizeof size_words > available) {
    throw Malformed("binary_compressed data declares " + std::to_string(compressed_size) +
                    " compressed bytes, the file holds " + std::to_string(available - sizeof size_words) +
                    " (truncated?)");
  }
  // An LZF back reference of 3 bytes makes at most 264: a larger claim is a garbage size word, and must not
  // allocate what it asks for.
  constexpr std::uint64_t kMaxLzfRatio = 88;
  if (unpacked_size > kMaxLzfRatio * compressed_size) {
    throw Malformed("binary_compressed data claims " + std::to_string(compressed_size) +
                    " compressed bytes unpack to " + std::to_string(unpacked_size) + ", more than LZF can");
  }
  std::vector<char> compressed(compressed_size), body(unpacked_size);
  if (!in.read(compressed.data(), std::streamsize(compressed_size)))
    throw Malformed("its binary_compressed data cannot be read");
  if (unpacked_size > 0 && pcl::lzfDecompress(compressed.data(), unsigned(compressed_size), body.data(),
                                              unsigned(unpacked_size)) != unpacked_size)
    throw Malformed("its binary_compressed data does not unpack to its " + std::to_string(unpacked_size) +
                    " bytes (a corrupt LZF stream)");
  std::uint64_t first[3], stride[3];
  for (int axis = 0; axis < 3; ++axis) {
    first[axis] = h.points * layout.byte_offset[axis];
    stride[axis] = layout.type[axis].bytes;
  }
  decodePoints(body, first, stride, layout, h.points, points);
}

}  // namespace

FileCloud readPcdFile(const std::string& path, std::vector<std::string>& warnings) {
  LineReader reader(path);
  PcdHeader h = readPcdHeader(reader, warnings);
  const CoordinateLayout layout = coordinateLayout(h);
  const std::uint64_t size = fileSize(path);
  const std::uint64_t available = size > h.body_offset ? size - h.body_offset : 0;
  FileCloud cloud;
  if (h.data == "ascii")
    readAsciiBody(reader, h, layout, available, cloud.points);
  else if (h.data == "binary")
    readBinaryBody(reader.stream(), h, layout, available, cloud.points);
  else
    readCompressedBody(reader.stream(), h, layout, available, cloud.points);
  cloud.width = std::uint32_t(h.width);
  cloud.height = std::uint32_t(h.height);
  cloud.viewpoint = h.viewpoint;
  cloud.orientation = h.orientation;
  return cloud;
}

}  // namespace cloud_file
}  // namespace mac_registration
