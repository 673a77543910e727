// Numpy arrays to and from the library's points: the checks every array passes, read in place where the
// layout allows.
#include "arrays.hpp"

#include <pybind11/numpy.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "mac_registration/features/cloud_io.hpp"

namespace mac_registration {
namespace python {

namespace {

// ---- arrays in

// The checks every point array passes: a float dtype, two dimensions, three columns. The name says which
// argument in the message. Anything array-like (a list of lists) goes through numpy.asarray first.
py::array pointArray(const py::handle& object, const char* name) {
  const py::array array = py::array::ensure(object);
  if (!array)
    throw py::type_error(std::string(name) + ": expected an (N, 3) array of points, got " +
                         std::string(py::str(py::type::handle_of(object).attr("__name__"))));
  const char kind = array.dtype().kind();
  if (kind != 'f') {
    throw py::type_error(std::string(name) + ": dtype " + std::string(py::str(array.dtype())) +
                         " is not a float type: give float32 or float64 coordinates in metres (e.g. " + name +
                         ".astype(numpy.float64))");
  }
  if (array.ndim() != 2 || array.shape(1) != 3) {
    std::ostringstream shape;
    shape << "(";
    for (py::ssize_t d = 0; d < array.ndim(); ++d) shape << (d ? ", " : "") << array.shape(d);
    shape << (array.ndim() == 1 ? ",)" : ")");
    throw py::value_error(
        std::string(name) + ": expected an (N, 3) array of points, got shape " + shape.str() +
        (array.ndim() == 2 && array.shape(1) > 3 ? " (take the x, y, z columns: points[:, :3])" : ""));
  }
  return array;
}

// Calls put(i, x, y, z) for each row, read in place whatever the array's strides (C or Fortran order, a
// slice, a view of a wider array): native float32 and float64 without a copy, other floats (float16,
// longdouble, another byte order) through one conversion to float64.
template <typename Put>
void forEachPoint(const py::array& array, Put&& put) {
  const auto read = [&](auto proxy) {
    for (py::ssize_t i = 0; i < proxy.shape(0); ++i)
      put(static_cast<Eigen::Index>(i), double(proxy(i, 0)), double(proxy(i, 1)), double(proxy(i, 2)));
  };
  if (py::isinstance<py::array_t<float>>(array)) {
    read(array.unchecked<float, 2>());
  } else if (py::isinstance<py::array_t<double>>(array)) {
    read(array.unchecked<double, 2>());
  } else {
    const auto converted = py::array_t<double, py::array::forcecast>::ensure(array);
    if (!converted) throw py::value_error("cannot convert the points to float64");
    read(converted.unchecked<2>());
  }
}

}  // namespace

Eigen::Matrix3Xd toMatrix(const py::handle& object, const char* name) {
  const py::array array = pointArray(object, name);
  Eigen::Matrix3Xd points(3, array.shape(0));
  forEachPoint(array, [&](Eigen::Index i, double x, double y, double z) { points.col(i) << x, y, z; });
  return points;
}

// A cloud as the front end takes it. `viewpoint`: where its sensor was (the free-space verification needs
// it; a PCD's VIEWPOINT); None = the origin of the cloud's frame, as for a scan in its sensor's frame.
PointCloud::Ptr toCloud(const py::handle& object, const char* name, const py::object& viewpoint,
                        const std::string& viewpoint_name, const Eigen::Vector3d& origin) {
  const py::array array = pointArray(object, name);
  if (array.shape(0) == 0)
    throw py::value_error(std::string(name) + ": the cloud is empty (shape (0, 3)): nothing to register");
  auto cloud = std::make_shared<PointCloud>();
  cloud->resize(static_cast<std::size_t>(array.shape(0)));
  cloud->width = static_cast<std::uint32_t>(array.shape(0));
  cloud->height = 1;
  cloud->is_dense = false;
  forEachPoint(array, [&](Eigen::Index i, double x, double y, double z) {
    auto& p = (*cloud)[static_cast<std::size_t>(i)];
    p.x = static_cast<float>(x - origin.x());
    p.y = static_cast<float>(y - origin.y());
    p.z = static_cast<float>(z - origin.z());
  });
  if (!viewpoint.is_none()) {
    const auto v = py::array_t<double, py::array::forcecast>::ensure(viewpoint);
    if (!v || v.size() != 3) throw py::value_error(viewpoint_name + ": expected 3 coordinates (x, y, z) [m]");
    cloud->sensor_origin_ = Eigen::Vector4f(float(v.data()[0] - origin.x()), float(v.data()[1] - origin.y()),
                                            float(v.data()[2] - origin.z()), 1.0f);
  }
  return cloud;
}

// The local origin loadLocalCloud would take for these points (features/cloud_io.hpp), from the array's own
// values (float64: a UTM map to the millimetre), before any float.
Eigen::Vector3d localOriginOf(const py::handle& object, const char* name) {
  const py::array array = pointArray(object, name);
  std::vector<Eigen::Vector3d> points(static_cast<std::size_t>(array.shape(0)));
  forEachPoint(array, [&](Eigen::Index i, double x, double y, double z) {
    points[static_cast<std::size_t>(i)] = Eigen::Vector3d(x, y, z);
  });
  return localOrigin(points);
}

Eigen::Vector3d vector3Of(const py::object& object, const char* name) {
  const auto v = py::array_t<double, py::array::forcecast>::ensure(object);
  if (!v || v.size() != 3)
    throw py::value_error(std::string(name) + ": expected 3 coordinates (x, y, z) [m]");
  return Eigen::Vector3d(v.data()[0], v.data()[1], v.data()[2]);
}

// ---- arrays out

// (K, 3) float64 from 3 x K column-major: the same bytes.
py::array_t<double> rowsOf(const Eigen::Matrix3Xd& points) {
  py::array_t<double> out({static_cast<py::ssize_t>(points.cols()), py::ssize_t{3}});
  if (points.size() > 0) std::memcpy(out.mutable_data(), points.data(), sizeof(double) * points.size());
  return out;
}

// (N, 3) float32: the cloud's own coordinates, exactly.
py::array_t<float> rowsOf(const PointCloud& cloud) {
  py::array_t<float> out({static_cast<py::ssize_t>(cloud.size()), py::ssize_t{3}});
  auto view = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    view(py::ssize_t(i), 0) = cloud[i].x;
    view(py::ssize_t(i), 1) = cloud[i].y;
    view(py::ssize_t(i), 2) = cloud[i].z;
  }
  return out;
}

}  // namespace python
}  // namespace mac_registration
