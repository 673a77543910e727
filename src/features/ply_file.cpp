// PLY files: the header is checked whole, then the body is walked element by element, as the header
// declares them, and the vertex element's x, y and z are read. PCL's own reader is not used: it reads a
// Stanford range scan's `range_grid` element (one list a grid cell, after the vertices) as an organised
// cloud of the grid's size, cannot convert double or integer coordinates into PointXYZ (every point became
// the origin), allocates what a garbage count asks for and fails on a short file without a reason.
#include <algorithm>
#include <cctype>
#include <map>

#include "cloud_file_parsing.hpp"

namespace mac_registration {
namespace cloud_file {
namespace {

struct PlyProperty {
  std::string name;
  bool is_list = false;
  ScalarType length_type;  // of a list's length
  ScalarType type;         // of the value, or of a list's entries
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
  bool has_lists = false;
  // Per instance, without the entries of its lists: what every instance takes at least.
  std::uint64_t min_bytes = 0, min_values = 0;
};

struct PlyHeader {
  std::string format;
  std::vector<PlyElement> elements;
  std::size_t vertex = 0;   // the vertex element's index
  std::size_t xyz[3] = {};  // the indices of x, y and z among its properties
};

ScalarType plyScalarType(const std::string& name) {
  using S = ScalarType;
  static const std::map<std::string, ScalarType> kTypes = {
      {"char", {S::kSigned, 1}},     {"int8", {S::kSigned, 1}},     {"uchar", {S::kUnsigned, 1}},
      {"uint8", {S::kUnsigned, 1}},  {"short", {S::kSigned, 2}},    {"int16", {S::kSigned, 2}},
      {"ushort", {S::kUnsigned, 2}}, {"uint16", {S::kUnsigned, 2}}, {"int", {S::kSigned, 4}},
      {"int32", {S::kSigned, 4}},    {"uint", {S::kUnsigned, 4}},   {"uint32", {S::kUnsigned, 4}},
      {"float", {S::kFloat, 4}},     {"float32", {S::kFloat, 4}},   {"double", {S::kFloat, 8}},
      {"float64", {S::kFloat, 8}}};
  const auto at = kTypes.find(name);
  if (at == kTypes.end()) throw Malformed("unknown property type " + fileText(name));
  return at->second;
}

void addProperty(const std::vector<std::string>& words, const std::string& where, PlyElement& element) {
  PlyProperty property;
  if (words.size() == 5 && words[1] == "list") {
    property.is_list = true;
    property.length_type = plyScalarType(words[2]);
    property.type = plyScalarType(words[3]);
    property.name = words[4];
    if (property.length_type.kind == ScalarType::kFloat)
      throw Malformed("list " + fileText(property.name) + " has a length of type " + fileText(words[2]) +
                      ", not an integer" + where);
    element.has_lists = true;
    element.min_bytes += property.length_type.bytes;  // the list's length; its entries may be none
  } else if (words.size() == 3) {
    property.type = plyScalarType(words[1]);
    property.name = words[2];
    element.min_bytes += property.type.bytes;
  } else {
    throw Malformed("property line " + joinedWords(words) +
                    " is not 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'" + where);
  }
  element.min_values += 1;
  for (const auto& other : element.properties) {
    if (other.name == property.name)
      throw Malformed("two properties named " + fileText(property.name) + " in element " +
                      fileText(element.name));
  }
  element.properties.push_back(property);
}

// Finds the vertex element and its coordinates. Coordinates of any numeric type are read (Open3D writes
// doubles; integer coordinates are as legal in the format): one scalar each.
void findCoordinates(PlyHeader& h) {
  const auto vertex = std::find_if(h.elements.begin(), h.elements.end(),
                                   [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex == h.elements.end()) throw Malformed("no vertex element with x, y and z");
  h.vertex = std::size_t(vertex - h.elements.begin());
  for (int axis = 0; axis < 3; ++axis) {
    const auto at = std::find_if(vertex->properties.begin(), vertex->properties.end(),
                                 [&](const PlyProperty& p) { return p.name == std::string(1, "xyz"[axis]); });
    if (at == vertex->properties.end() || at->is_list) throw Malformed("no vertex element with x, y and z");
    h.xyz[axis] = std::size_t(at - vertex->properties.begin());
  }
}

PlyHeader readPlyHeader(LineReader& reader) {
  std::vector<std::string> words;
  if (!reader.next(words) || words != std::vector<std::string>{"ply"})
    throw Malformed("no header from 'ply' to 'end_header'");
  PlyHeader h;
  for (bool ended = false; !ended;) {
    if (!reader.next(words)) throw Malformed("no header from 'ply' to 'end_header'");
    if (words.empty()) continue;
    const std::string& key = words[0];
    const std::string where = " (header line " + std::to_string(reader.line()) + ")";
    if (key == "comment" || key == "obj_info") {
      continue;
    } else if (key == "format") {
      if (!h.format.empty()) throw Malformed("two format lines");
      if (words.size() != 3 || words[2] != "1.0" ||
          (words[1] != "ascii" && words[1] != "binary_little_endian" && words[1] != "binary_big_endian"))
        throw Malformed("format " + joinedWords(words) +
                        " is not ascii, binary_little_endian or binary_big_endian 1.0");
      h.format = words[1];
    } else if (key == "element") {
      PlyElement element;
      if (words.size() != 3 || !parseCount(words[2], kMaxPoints, element.count))
        throw Malformed("element line " + joinedWords(words) + " needs a name and a count" + where);
      element.name = words[1];
      h.elements.push_back(element);
    } else if (key == "property") {
      if (h.elements.empty()) throw Malformed("a property before any element" + where);
      addProperty(words, where, h.elements.back());
    } else if (key == "end_header") {
      ended = true;
    } else {
      throw Malformed("unknown header line " + joinedWords(words) + where);
    }
  }
  if (h.format.empty()) throw Malformed("no format line");
  findCoordinates(h);
  return h;
}

std::string instanceOf(const PlyElement& e, std::uint64_t instance) {
  return "element " + fileText(e.name) + " (" + std::to_string(instance + 1) + " of " +
         std::to_string(e.count) + ")";
}

// The whitespace-separated words of an ascii body, with the line each comes from.
class WordReader {
 public:
  WordReader(std::istream& in, int lines_before) : in_(*in.rdbuf()), line_(lines_before + 1) {}

  // False at the end of the file.
  bool next(std::string& word) {
    constexpr std::size_t kMaxWord = 256;  // no number is longer; binary data must not be read whole
    word.clear();
    int c = in_.sbumpc();
    for (; c != EOF && std::isspace(c); c = in_.sbumpc()) line_ += c == '\n';
    word_line_ = line_;
    for (; c != EOF && !std::isspace(c); c = in_.sbumpc()) {
      if (word.size() == kMaxWord)
        throw Malformed("line " + std::to_string(line_) + ": a word of more than " +
                        std::to_string(kMaxWord) + " bytes, not a number");
      word.push_back(static_cast<char>(c));
    }
    line_ += c == '\n';
    words_ += !word.empty();
    return !word.empty();
  }

  int line() const { return word_line_; }  // of the word last read
  std::uint64_t words() const { return words_; }

 private:
  std::streambuf& in_;
  int line_, word_line_ = 0;
  std::uint64_t words_ = 0;
};

// Every element walked (lists parsed by their lengths, every value a number), the vertices' coordinates
// kept: a file that disagrees with its header anywhere is refused.
void readAsciiBody(LineReader& reader, const PlyHeader& h, std::uint64_t available,
                   std::vector<Eigen::Vector3d>& points) {
  std::uint64_t needed = 0;
  for (const auto& e : h.elements)
    needed = checkedSum(needed, checkedProduct(e.count, e.min_values, "element count x values"),
                        "the elements' values");
  const PlyElement& vertex = h.elements[h.vertex];
  points.reserve(std::min(vertex.count, available / (2 * vertex.min_values)));  // garbage counts
  WordReader words(reader.stream(), reader.line());
  std::string word;
  const auto nextNumber = [&](const PlyElement& e, std::uint64_t instance) {
    if (!words.next(word)) {
      if (words.words() < needed)
        throw Malformed("its elements need at least " + std::to_string(needed) + " ascii values, it holds " +
                        std::to_string(words.words()) + " (truncated?)");
      throw Malformed("its data ends inside " + instanceOf(e, instance) + " (truncated?)");
    }
    double value = 0.0;
    if (!parseNumber(word, value))
      throw Malformed("line " + std::to_string(words.line()) + ": " + fileText(word) + " is not a number");
    return value;
  };
  for (const auto& e : h.elements) {
    const bool is_vertex = &e == &vertex;
    double xyz[3] = {};
    for (std::uint64_t instance = 0; instance < e.count; ++instance) {
      for (std::size_t p = 0; p < e.properties.size(); ++p) {
        const double value = nextNumber(e, instance);
        if (!e.properties[p].is_list) {
          for (int axis = 0; axis < 3; ++axis) {
            if (is_vertex && p == h.xyz[axis]) xyz[axis] = value;
          }
          continue;
        }
        std::uint64_t length = 0;
        if (!parseCount(word, std::numeric_limits<std::uint32_t>::max(), length))
          throw Malformed("line " + std::to_string(words.line()) + ": list length " + fileText(word) +
                          " is not a whole number");
        for (std::uint64_t k = 0; k < length; ++k) nextNumber(e, instance);
      }
      if (is_vertex) points.emplace_back(xyz[0], xyz[1], xyz[2]);
    }
  }
}

// The body read forward, never past the end of the file.
class BinaryBody {
 public:
  BinaryBody(std::istream& in, std::uint64_t available) : in_(in), left_(available) {}

  void read(char* out, std::uint64_t bytes, const PlyElement& e, std::uint64_t instance) {
    take(bytes, e, instance);
    if (!in_.read(out, std::streamsize(bytes))) throw Malformed("its binary data cannot be read");
  }
  void skip(std::uint64_t bytes, const PlyElement& e, std::uint64_t instance) {
    take(bytes, e, instance);
    if (!in_.seekg(std::streamoff(bytes), std::ios::cur)) throw Malformed("its binary data cannot be read");
  }

 private:
  void take(std::uint64_t bytes, const PlyElement& e, std::uint64_t instance) {
    if (bytes > left_) throw Malformed("its data ends inside " + instanceOf(e, instance) + " (truncated?)");
    left_ -= bytes;
  }

  std::istream& in_;
  std::uint64_t left_;
};

// Vertices without lists: records of one size, read many at a time.
void readVertexRecords(BinaryBody& body, const PlyHeader& h, bool little_endian,
                       std::vector<Eigen::Vector3d>& points) {
  const PlyElement& e = h.elements[h.vertex];
  std::uint64_t offset[3] = {};
  for (int axis = 0; axis < 3; ++axis) {
    for (std::size_t p = 0; p < h.xyz[axis]; ++p) offset[axis] += e.properties[p].type.bytes;
  }
  points.resize(e.count);
  constexpr std::uint64_t kBatch = 1 << 16;
  std::vector<char> records;
  for (std::uint64_t first = 0; first < e.count; first += kBatch) {
    const std::uint64_t n = std::min(kBatch, e.count - first);
    records.resize(n * e.min_bytes);
    body.read(records.data(), records.size(), e, first);
    for (std::uint64_t k = 0; k < n; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        const PlyProperty& p = e.properties[h.xyz[axis]];
        points[first + k][axis] =
            decodeScalar(records.data() + k * e.min_bytes + offset[axis], p.type, little_endian);
      }
    }
  }
}

// An element with lists, instance by instance; the vertices' coordinates kept.
void walkInstances(BinaryBody& body, const PlyHeader& h, std::size_t element, bool little_endian,
                   std::vector<Eigen::Vector3d>& points) {
  const PlyElement& e = h.elements[element];
  const bool is_vertex = element == h.vertex;
  char scalar[8];
  for (std::uint64_t instance = 0; instance < e.count; ++instance) {
    double xyz[3] = {};
    for (std::size_t p = 0; p < e.properties.size(); ++p) {
      const PlyProperty& property = e.properties[p];
      if (!property.is_list) {
        body.read(scalar, property.type.bytes, e, instance);
        for (int axis = 0; axis < 3; ++axis) {
          if (is_vertex && p == h.xyz[axis]) xyz[axis] = decodeScalar(scalar, property.type, little_endian);
        }
        continue;
      }
      body.read(scalar, property.length_type.bytes, e, instance);
      const double length = decodeScalar(scalar, property.length_type, little_endian);
      if (length < 0)
        throw Malformed("a list of length " + std::to_string(std::int64_t(length)) + " in " +
                        instanceOf(e, instance));
      body.skip(std::uint64_t(length) * property.type.bytes, e, instance);  // length < 2^32: no overflow
    }
    if (is_vertex) points.emplace_back(xyz[0], xyz[1], xyz[2]);
  }
}

// The elements up to the vertices (what follows them is not needed; the file's size covers their least
// size), every element without lists skipped whole.
void readBinaryBody(std::istream& in, const PlyHeader& h, std::uint64_t available,
                    std::vector<Eigen::Vector3d>& points) {
  std::uint64_t needed = 0;
  for (const auto& e : h.elements)
    needed = checkedSum(needed, checkedProduct(e.count, e.min_bytes, "element count x size"),
                        "the elements' declared size");
  const PlyElement& vertex = h.elements[h.vertex];
  if (available < needed) {
    throw Malformed("its elements (" + std::to_string(vertex.count) + " vertices of " +
                    std::to_string(vertex.min_bytes) + " bytes, ...) need at least " +
                    std::to_string(needed) + " bytes after the header, the file holds " +
                    std::to_string(available) + " (truncated?)");
  }
  const bool little_endian = h.format == "binary_little_endian";
  BinaryBody body(in, available);
  for (std::size_t i = 0; i < h.vertex; ++i) {
    const PlyElement& e = h.elements[i];
    if (e.has_lists)
      walkInstances(body, h, i, little_endian, points);
    else
      body.skip(e.count * e.min_bytes, e, 0);  // checked above: no overflow
  }
  if (vertex.has_lists) {
    points.reserve(vertex.count);  // the file holds at least the count's minimum size: bounded
    walkInstances(body, h, h.vertex, little_endian, points);
  } else {
    readVertexRecords(body, h, little_endian, points);
  }
}

}  // namespace

FileCloud readPlyFile(const std::string& path) {
  LineReader reader(path);
  const PlyHeader h = readPlyHeader(reader);
  const std::uint64_t size = fileSize(path);
  const std::uint64_t available = size > reader.offset() ? size - reader.offset() : 0;
  FileCloud cloud;
  if (h.format == "ascii")
    readAsciiBody(reader, h, available, cloud.points);
  else
    readBinaryBody(reader.stream(), h, available, cloud.points);
  cloud.width = std::uint32_t(cloud.points.size());
  cloud.height = 1;
  return cloud;
}

}  // namespace cloud_file
}  // namespace mac_registration
