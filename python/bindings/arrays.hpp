#pragma once

// Numpy arrays in and out of the module: (N, 3) point arrays of any float dtype and any strides, read in
// place for native float32 and float64; float64 / float32 rows out.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <string>

#include "mac_registration/features/point_cloud.hpp"

namespace mac_registration {
namespace python {

namespace py = pybind11;

// A (N, 3) float array as 3 x N doubles; ValueError / TypeError naming `name` when it is not one.
Eigen::Matrix3Xd toMatrix(const py::handle& object, const char* name);

// A cloud as the front end takes it, each point less `origin`. `viewpoint`: where its sensor was (the
// free-space verification needs it; a PCD's VIEWPOINT); None = the origin of the cloud's frame, as for a
// scan in its sensor's frame. ValueError for an empty cloud.
PointCloud::Ptr toCloud(const py::handle& object, const char* name, const py::object& viewpoint,
                        const std::string& viewpoint_name,
                        const Eigen::Vector3d& origin = Eigen::Vector3d::Zero());

// The local origin loadLocalCloud would take for these points (features/cloud_io.hpp), from the array's own
// values (float64: a UTM map to the millimetre), before any float.
Eigen::Vector3d localOriginOf(const py::handle& object, const char* name);

// Three coordinates [m]; ValueError naming `name` otherwise.
Eigen::Vector3d vector3Of(const py::object& object, const char* name);

// (K, 3) float64 from 3 x K column-major: the same bytes.
py::array_t<double> rowsOf(const Eigen::Matrix3Xd& points);
// (N, 3) float32: the cloud's own coordinates, exactly.
py::array_t<float> rowsOf(const PointCloud& cloud);

}  // namespace python
}  // namespace mac_registration
