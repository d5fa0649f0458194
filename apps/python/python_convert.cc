#include "apps/python/python_convert.h"

#include <cmath>

#include <glog/logging.h>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

namespace py = pybind11;

namespace ieslam {

OptionText OptionTextFromPython(const py::handle& value, const std::string& name,
                                const std::string& where) {
  // bool before int: a Python bool is an int.
  if (py::isinstance<py::bool_>(value)) return {value.cast<bool>() ? "1" : "0", false};
  if (py::isinstance<py::int_>(value)) return {py::str(value), false};
  if (py::isinstance<py::float_>(value)) return {py::repr(value), false};
  if (py::isinstance<py::str>(value)) return {value.cast<std::string>(), true};
  throw ConfigError(where + ": " + name + " must be a bool, an int, a float or a str, got " +
                    std::string(py::str(py::type::of(value).attr("__name__"))));
}

py::array_t<double> TrajectoryToArray(const Trajectory& trajectory) {
  py::array_t<double> array({static_cast<py::ssize_t>(trajectory.size()), py::ssize_t{8}});
  auto a = array.mutable_unchecked<2>();
  for (size_t i = 0; i < trajectory.size(); ++i) {
    const TimedPose& pose = trajectory[i];
    Eigen::Quaterniond q(pose.T_w_c.linear());
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    const Eigen::Vector3d& t = pose.T_w_c.translation();
    const double row[8] = {pose.timestamp, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
    for (int c = 0; c < 8; ++c) a(i, c) = row[c];
  }
  return array;
}

Trajectory ArrayToTrajectory(const py::array_t<double>& array, const std::string& name) {
  if (array.ndim() != 2 || array.shape(1) != 8) {
    throw DataError(name + ": expected an N x 8 array (t x y z qx qy qz qw)");
  }
  const auto a = array.unchecked<2>();
  Trajectory trajectory(static_cast<size_t>(array.shape(0)));
  for (py::ssize_t i = 0; i < array.shape(0); ++i) {
    Eigen::Quaterniond q(a(i, 7), a(i, 4), a(i, 5), a(i, 6));
    bool finite = std::isfinite(q.norm());
    for (int c = 0; c < 4; ++c) finite &= std::isfinite(a(i, c));
    if (!finite || q.norm() < 1e-12) {
      throw DataError(name + ": row " + std::to_string(i) +
                      " holds a non-finite value or a zero quaternion");
    }
    TimedPose& pose = trajectory[static_cast<size_t>(i)];
    pose.timestamp = a(i, 0);
    pose.T_w_c.linear() = q.normalized().toRotationMatrix();
    pose.T_w_c.translation() = Eigen::Vector3d(a(i, 1), a(i, 2), a(i, 3));
  }
  return trajectory;
}

py::array_t<uint8_t> ColourToArray(const cv::Mat& bgr) {
  CHECK_EQ(bgr.type(), CV_8UC3);
  py::array_t<uint8_t> array({bgr.rows, bgr.cols, 3});
  cv::Mat rgb(bgr.rows, bgr.cols, CV_8UC3, array.mutable_data());
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return array;
}

py::array_t<float> DepthToArray(const cv::Mat& depth) {
  CHECK_EQ(depth.type(), CV_32FC1);
  py::array_t<float> array({depth.rows, depth.cols});
  cv::Mat out(depth.rows, depth.cols, CV_32FC1, array.mutable_data());
  depth.copyTo(out);
  return array;
}

py::object JsonToPython(const Json& json) {
  // Json prints doubles so that they read back the same; Python's parser reads them so.
  return py::module_::import("json").attr("loads")(json.Dump(0));
}

}  // namespace ieslam
