#include "mac_registration/features/cloud_io.hpp"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

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

// Thrown by the header checks; loadCloud adds the file and the format.
struct Malformed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A text file read line by line, with the byte offset where the last line read ends (where a binary
// body starts). Lines are bounded in length: a binary file without a header must not be read whole.
class LineReader {
 public:
  explicit LineReader(const std::string& path) : in_(path, std::ios::binary) {
    if (!in_) throw std::runtime_error("cannot open '" + path + "' for reading");
  }

  // The whitespace-separated words of the next line; false at the end of the file.
  bool next(std::vector<std::string>& words) {
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

  int line() const { return line_; }
  std::uint64_t offset() const { return offset_; }

 private:
  std::ifstream in_;
  int line_ = 0;
  std::uint64_t offset_ = 0;
};

// A whole non-negative decimal number no larger than `max`, or false.
bool parseCount(const std::string& word, std::uint64_t max, std::uint64_t& value) {
  if (word.empty() || word.size() > 19 ||
      !std::all_of(word.begin(), word.end(), [](unsigned char c) { return std::isdigit(c); }))
    return false;
  value = std::stoull(word);
  return value <= max;
}

// a x b, or a Malformed error naming `what` when it does not fit in 64 bits (a garbage count).
std::uint64_t checkedProduct(std::uint64_t a, std::uint64_t b, const std::string& what) {
  std::uint64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product)) throw Malformed(what + " overflows 64 bits");
  return product;
}

std::uint64_t checkedSum(std::uint64_t a, std::uint64_t b) {
  std::uint64_t sum = 0;
  if (__builtin_add_overflow(a, b, &sum)) throw Malformed("the elements' declared size overflows 64 bits");
  return sum;
}

bool isNumber(const std::string& word) {
  char* end = nullptr;
  std::strtod(word.c_str(), &end);
  return !word.empty() && end == word.c_str() + word.size();
}

// PCL keeps point counts in int.
constexpr std::uint64_t kMaxPoints = std::numeric_limits<std::int32_t>::max();

// Text from a file, in quotes, fit for a one-line message: a binary file's bytes would garble the terminal
// that shows it, so bytes outside printable ASCII appear as \xNN, and text mostly made of them, which the
// escapes would not make readable, is only summarised. Long text is cut.
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

std::uint64_t fileSize(const std::string& path) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (error) throw std::runtime_error("cannot read cloud '" + path + "': " + error.message());
  return size;
}

// ---- PCD (v0.7, what PCL writes): the header is checked whole before PCL sees the file, because PCL's
// reader trusts it: an unknown line or a missing field list makes PCL 1.13 dereference a null pointer,
// a huge WIDTH makes it allocate without bound, a short binary body is read past its end, and ascii lines
// with the wrong number of values are only a warning.

struct PcdHeader {
  std::vector<std::string> fields;
  std::vector<std::uint64_t> sizes, counts;
  std::vector<char> types;
  std::uint64_t width = 0, height = 1, points = 0;
  std::string data;
  std::uint64_t body_offset = 0;

  std::uint64_t pointBytes() const {  // sizes <= 8, counts <= 2^20, fields < 2^16: no overflow
    std::uint64_t bytes = 0;
    for (std::size_t i = 0; i < fields.size(); ++i) bytes += sizes[i] * counts[i];
    return bytes;
  }
  std::uint64_t valuesPerPoint() const {
    std::uint64_t values = 0;
    for (const auto c : counts) values += c;
    return values;
  }
};

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
    for (const auto& v : values) {
      if (v != "F" && v != "I" && v != "U") throw Malformed("TYPE " + fileText(v) + " is not F, I or U");
      h.types.push_back(v[0]);
    }
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
    if (values.size() != 7 || !std::all_of(values.begin(), values.end(), isNumber))
      throw Malformed("VIEWPOINT needs 7 numbers (tx ty tz qw qx qy qz)");
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

void checkPcdFields(PcdHeader& h) {
  const std::size_t n = h.fields.size();
  if (h.counts.empty()) h.counts.assign(n, 1);  // COUNT is optional
  if (h.sizes.size() != n || h.types.size() != n || h.counts.size() != n) {
    throw Malformed(std::to_string(n) + " FIELDS but " + std::to_string(h.sizes.size()) + " SIZE, " +
                    std::to_string(h.types.size()) + " TYPE and " + std::to_string(h.counts.size()) +
                    " COUNT values");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (h.types[i] == 'F' && h.sizes[i] != 4 && h.sizes[i] != 8)
      throw Malformed("field " + fileText(h.fields[i]) + " is F of " + std::to_string(h.sizes[i]) + " bytes");
  }
  for (const char* axis : {"x", "y", "z"}) {
    const auto at = std::find(h.fields.begin(), h.fields.end(), axis);
    if (at == h.fields.end()) throw Malformed("no FIELDS x y z");
    const std::size_t i = std::size_t(at - h.fields.begin());
    if (h.types[i] != 'F' || h.counts[i] != 1)
      throw Malformed(std::string("field '") + axis + "' is not one float (TYPE F, COUNT 1)");
  }
}

// PCL's ascii reader fills what a short line lacks and warns "possibly malformed": here it is an error.
void checkPcdAsciiBody(LineReader& reader, const PcdHeader& h) {
  const std::uint64_t values = h.valuesPerPoint();
  std::uint64_t rows = 0;
  for (std::vector<std::string> words; reader.next(words);) {
    if (words.empty()) continue;
    if (rows == h.points)
      throw Malformed("more data lines than its " + std::to_string(h.points) + " POINTS (line " +
                      std::to_string(reader.line()) + ")");
    if (words.size() != values) {
      throw Malformed("line " + std::to_string(reader.line()) + " holds " + std::to_string(words.size()) +
                      " values, not " + std::to_string(values));
    }
    for (const auto& word : words) {
      if (!isNumber(word))
        throw Malformed("line " + std::to_string(reader.line()) + ": " + fileText(word) + " is not a number");
    }
    ++rows;
  }
  if (rows < h.points) {
    throw Malformed("POINTS " + std::to_string(h.points) + " but " + std::to_string(rows) +
                    " data lines (truncated?)");
  }
}

void checkPcdBinaryBody(const std::string& path, const PcdHeader& h) {
  const std::uint64_t size = fileSize(path);
  const std::uint64_t available = size > h.body_offset ? size - h.body_offset : 0;
  const std::uint64_t needed = checkedProduct(h.points, h.pointBytes(), "POINTS x point size");
  if (h.data == "binary") {
    if (available < needed) {
      throw Malformed(std::to_string(h.points) + " points of " + std::to_string(h.pointBytes()) +
                      " bytes need " + std::to_string(needed) + " bytes of binary data, the file holds " +
                      std::to_string(available) + " (truncated?)");
    }
    return;
  }
  // binary_compressed: two uint32 (compressed size, uncompressed size), then the LZF stream.
  std::uint32_t sizes[2] = {0, 0};
  std::ifstream in(path, std::ios::binary);
  in.seekg(std::streamoff(h.body_offset));
  if (available < sizeof sizes || !in.read(reinterpret_cast<char*>(sizes), sizeof sizes))
    throw Malformed("binary_compressed data without its two size words");
  if (sizes[1] != needed) {
    throw Malformed("binary_compressed data unpacks to " + std::to_string(sizes[1]) + " bytes, but " +
                    std::to_string(h.points) + " points of " + std::to_string(h.pointBytes()) +
                    " bytes are " + std::to_string(needed));
  }
  if (std::uint64_t(sizes[0]) + sizeof sizes > available) {
    throw Malformed("binary_compressed data declares " + std::to_string(sizes[0]) +
                    " compressed bytes, the file holds " + std::to_string(available - sizeof sizes) +
                    " (truncated?)");
  }
}

// Returns the number of points the file declares.
std::uint64_t checkPcdFile(const std::string& path) {
  static const std::set<std::string> kKeywords = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                                  "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
  LineReader reader(path);
  PcdHeader h;
  std::set<std::string> seen;
  bool points_given = false;
  for (std::vector<std::string> words; h.data.empty();) {
    if (!reader.next(words)) throw Malformed("no header ending in a DATA line");
    if (words.empty() || words[0][0] == '#') continue;
    if (!kKeywords.count(words[0])) {
      throw Malformed(
          "unknown header line " + std::to_string(reader.line()) + " " + joinedWords(words) +
          "; a header has only VERSION FIELDS SIZE TYPE COUNT WIDTH HEIGHT VIEWPOINT POINTS DATA");
    }
    if (!seen.insert(words[0]).second) throw Malformed(words[0] + " appears twice in the header");
    parsePcdLine(words, h);
    points_given |= words[0] == "POINTS";
  }
  h.body_offset = reader.offset();
  for (const char* required : {"FIELDS", "SIZE", "TYPE", "WIDTH"}) {
    if (!seen.count(required)) throw Malformed(std::string("no ") + required + " line in the header");
  }
  checkPcdFields(h);
  const std::uint64_t grid = h.width * h.height;  // both <= 2^31: no overflow
  if (!points_given) h.points = grid;
  if (grid != h.points) {
    throw Malformed("WIDTH x HEIGHT = " + std::to_string(h.width) + " x " + std::to_string(h.height) +
                    " is not POINTS " + std::to_string(h.points));
  }
  if (h.data == "ascii")
    checkPcdAsciiBody(reader, h);
  else
    checkPcdBinaryBody(path, h);
  return h.points;
}

// ---- PLY: the header the same way, and the body at least as long as its elements need (PCL's reader
// otherwise allocates what a garbage count asks for, or fails with no reason).

std::uint64_t plyScalarBytes(const std::string& type) {
  static const std::map<std::string, std::uint64_t> kSizes = {
      {"char", 1},  {"uchar", 1},   {"int8", 1},   {"uint8", 1},  {"short", 2}, {"ushort", 2},
      {"int16", 2}, {"uint16", 2},  {"int", 4},    {"uint", 4},   {"int32", 4}, {"uint32", 4},
      {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
  const auto at = kSizes.find(type);
  if (at == kSizes.end()) throw Malformed("unknown property type " + fileText(type));
  return at->second;
}

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  // Per instance, without the entries of its lists: what every instance takes at least.
  std::uint64_t min_bytes = 0, min_values = 0;
  std::vector<std::string> scalar_properties;
  std::map<std::string, std::string> scalar_types;
};

// Returns the number of vertices the file declares.
std::uint64_t checkPlyFile(const std::string& path) {
  LineReader reader(path);
  std::vector<std::string> words;
  if (!reader.next(words) || words != std::vector<std::string>{"ply"})
    throw Malformed("no header from 'ply' to 'end_header'");
  std::string format;
  std::vector<PlyElement> elements;
  for (bool ended = false; !ended;) {
    if (!reader.next(words)) throw Malformed("no header from 'ply' to 'end_header'");
    if (words.empty()) continue;
    const std::string& key = words[0];
    const std::string where = " (header line " + std::to_string(reader.line()) + ")";
    if (key == "comment" || key == "obj_info") {
      continue;
    } else if (key == "format") {
      if (!format.empty()) throw Malformed("two format lines");
      if (words.size() != 3 || words[2] != "1.0" ||
          (words[1] != "ascii" && words[1] != "binary_little_endian" && words[1] != "binary_big_endian"))
        throw Malformed("format " + joinedWords(words) +
                        " is not ascii, binary_little_endian or binary_big_endian 1.0");
      format = words[1];
    } else if (key == "element") {
      PlyElement element;
      if (words.size() != 3 || !parseCount(words[2], kMaxPoints, element.count))
        throw Malformed("element line " + joinedWords(words) + " needs a name and a count" + where);
      element.name = words[1];
      elements.push_back(element);
    } else if (key == "property") {
      if (elements.empty()) throw Malformed("a property before any element" + where);
      PlyElement& element = elements.back();
      if (words.size() == 5 && words[1] == "list") {
        element.min_bytes += plyScalarBytes(words[2]);  // the list's length; its entries may be none
        plyScalarBytes(words[3]);
        element.min_values += 1;
      } else if (words.size() == 3) {
        element.min_bytes += plyScalarBytes(words[1]);
        element.min_values += 1;
        if (element.scalar_types.count(words[2]))
          throw Malformed("two properties named " + fileText(words[2]) + " in element " +
                          fileText(element.name));
        element.scalar_properties.push_back(words[2]);
        element.scalar_types[words[2]] = words[1];
      } else {
        throw Malformed("property line " + joinedWords(words) +
                        " is not 'property TYPE NAME' or "
                        "'property list COUNT_TYPE TYPE NAME'" +
                        where);
      }
    } else if (key == "end_header") {
      ended = true;
    } else {
      throw Malformed("unknown header line " + joinedWords(words) + where);
    }
  }
  if (format.empty()) throw Malformed("no format line");
  const auto vertex =
      std::find_if(elements.begin(), elements.end(), [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex == elements.end()) throw Malformed("no vertex element with x, y and z");
  for (const char* axis : {"x", "y", "z"}) {
    const auto type = vertex->scalar_types.find(axis);
    if (type == vertex->scalar_types.end()) throw Malformed("no vertex element with x, y and z");
    static const std::set<std::string> kFloatTypes = {"float", "float32", "double", "float64"};
    if (!kFloatTypes.count(type->second))
      throw Malformed(std::string("vertex property '") + axis + "' is " + type->second + ", not a float");
  }
  if (format == "ascii") {
    std::uint64_t needed = 0, found = 0;
    for (const auto& e : elements)
      needed = checkedSum(needed, checkedProduct(e.count, e.min_values, "element count x values"));
    for (; found < needed && reader.next(words);) {
      for (const auto& word : words) {
        if (!isNumber(word))
          throw Malformed("line " + std::to_string(reader.line()) + ": " + fileText(word) +
                          " is not a number");
      }
      found += words.size();
    }
    if (found < needed) {
      throw Malformed("its elements need at least " + std::to_string(needed) + " ascii values, it holds " +
                      std::to_string(found) + " (truncated?)");
    }
  } else {
    std::uint64_t needed = 0;
    for (const auto& e : elements)
      needed = checkedSum(needed, checkedProduct(e.count, e.min_bytes, "element count x size"));
    const std::uint64_t size = fileSize(path);
    const std::uint64_t available = size > reader.offset() ? size - reader.offset() : 0;
    if (available < needed) {
      throw Malformed("its elements (" + std::to_string(vertex->count) + " vertices of " +
                      std::to_string(vertex->min_bytes) + " bytes, ...) need at least " +
                      std::to_string(needed) + " bytes after the header, the file holds " +
                      std::to_string(available) + " (truncated?)");
    }
  }
  return vertex->count;
}

// PCL's readers, with their exceptions turned into an error naming the file.
PointCloud::Ptr readWithPcl(const std::string& path, const std::string& extension) {
  auto cloud = pcl::make_shared<PointCloud>();
  int status = -1;
  try {
    status = extension == ".pcd" ? pcl::io::loadPCDFile(path, *cloud) : pcl::io::loadPLYFile(path, *cloud);
  } catch (const std::bad_alloc&) {
    throw std::runtime_error("cannot read cloud '" + path +
                             "': PCL ran out of memory reading it (std::bad_alloc)");
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot read cloud '" + path + "': PCL failed reading it (" + e.what() + ")");
  }
  if (status < 0) {
    throw std::runtime_error("cannot read cloud '" + path + "': not a valid " + extension +
                             " file (PCL's reader refused it, status " + std::to_string(status) + ")");
  }
  return cloud;
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
    std::uint64_t declared = 0;
    try {
      declared = extension == ".pcd" ? checkPcdFile(path) : checkPlyFile(path);
    } catch (const Malformed& e) {
      throw std::runtime_error("cannot read cloud '" + path + "': not a valid " + extension + " file (" +
                               e.what() + ")");
    }
    if (declared == 0) throw std::runtime_error("cloud '" + path + "' has no points");
    cloud = readWithPcl(path, extension);
    if (cloud->size() != declared) {
      throw std::runtime_error("cannot read cloud '" + path + "': PCL read " + std::to_string(cloud->size()) +
                               " points of the " + std::to_string(declared) + " it declares");
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
