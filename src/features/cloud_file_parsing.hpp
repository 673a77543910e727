// What the PCD and PLY readers behind loadCloud and loadLocalCloud share: the error they throw, the reading
// of a header line by line, the checked counts, the decoding of the numbers both formats store, and the
// cloud they read. Internal to the features library.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {
namespace cloud_file {

// A file that breaks its format; loadCloud adds the file's name and format to the reason.
struct Malformed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// PCL and the front end keep point counts in int.
constexpr std::uint64_t kMaxPoints = std::numeric_limits<std::int32_t>::max();

// A file read line by line, with the byte offset where the last line read ends (where a binary body
// starts). Lines are bounded in length: a binary file without a header must not be read whole.
class LineReader {
 public:
  explicit LineReader(const std::string& path);

  // The whitespace-separated words of the next line; false at the end of the file.
  bool next(std::vector<std::string>& words);

  int line() const { return line_; }
  std::uint64_t offset() const { return offset_; }
  // Positioned where the last line read ends.
  std::istream& stream() { return in_; }

 private:
  std::ifstream in_;
  int line_ = 0;
  std::uint64_t offset_ = 0;
};

// Text from a file, in quotes, fit for a one-line message: a binary file's bytes would garble the terminal
// that shows it, so bytes outside printable ASCII appear as \xNN, and text mostly made of them, which the
// escapes would not make readable, is only summarised. Long text is cut.
std::string fileText(const std::string& text);
// The words as fileText, joined by spaces.
std::string joinedWords(const std::vector<std::string>& words);

// A whole non-negative decimal number no larger than `max`, or false.
bool parseCount(const std::string& word, std::uint64_t max, std::uint64_t& value);
// The number `word` spells whole (strtod's syntax, nan and inf included), or false.
bool parseNumber(const std::string& word, double& value);

// a x b and a + b, or a Malformed error naming `what` when they do not fit in 64 bits (a garbage count).
std::uint64_t checkedProduct(std::uint64_t a, std::uint64_t b, const std::string& what);
std::uint64_t checkedSum(std::uint64_t a, std::uint64_t b, const std::string& what);

std::uint64_t fileSize(const std::string& path);

// A number as both formats store it: a signed or unsigned integer or an IEEE float, of 1, 2, 4 or 8 bytes.
struct ScalarType {
  enum Kind { kSigned, kUnsigned, kFloat } kind = kFloat;
  unsigned bytes = 4;
};

// The value stored at `bytes`, whatever the byte order of this machine.
double decodeScalar(const char* bytes, ScalarType type, bool little_endian);

// A cloud as its file stores it: the coordinates in double, so that a map in global coordinates keeps its
// millimetres until a local origin is taken off (loadLocalCloud); 24 bytes a point, freed once the front
// end's float cloud is made.
struct FileCloud {
  std::vector<Eigen::Vector3d> points;  // every point the file declares, in its order, NaNs included
  std::uint32_t width = 0, height = 1;  // an organised cloud's grid; unorganised: size() x 1
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();  // PCD's VIEWPOINT: where the sensor was
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
};

// A coordinate in the front end's float. Non-finite values stay what they are (the front end drops them);
// finite values beyond float's range become its largest, so that the coordinate bound refuses the file
// instead of the point turning into an infinity and being dropped in silence.
float toCoordinate(double value);

// The front end's cloud of `file`: each point less `origin`, subtracted in double, then in float; the grid
// and the viewpoint (less `origin` too) kept.
PointCloud::Ptr toPointCloud(const FileCloud& file, const Eigen::Vector3d& origin);

// The readers loadCloud and loadLocalCloud call once they have checked the path: every point the file
// declares, in its order, or a Malformed error. `warnings` receives what was read despite a fault of the
// file.
FileCloud readPcdFile(const std::string& path, std::vector<std::string>& warnings);
FileCloud readPlyFile(const std::string& path);

}  // namespace cloud_file
}  // namespace mac_registration
