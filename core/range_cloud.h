// A range image reduced to what dense alignment needs: an organised grid of 3-D points with
// surface normals and range noise, every `step`-th range pixel in each direction.
//
// The grid keeps the range imager's pixel layout (a pinhole with the intrinsics divided by
// the step), so a point from another view is associated with this cloud by projecting it
// into the grid (projective data association, as KinectFusion does) instead of searching a
// tree. Points are in the range imager's frame; T_colour_range places them in the colour
// camera's, whose poses the estimators hold.
#pragma once

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/option_table.h"

namespace ieslam {

struct RangeCloudOptions {
  int step = 4;  // range pixels between grid points, in each direction
  // A grid point's normal is the least-squares plane through the range points within `step`
  // pixels of it (every step / 2-th pixel: 25 points), as Open3D and PCL estimate normals;
  // a difference of two neighbours instead is noisy (range noise over a few millimetres
  // between pixels) and blends two planes at a crease (docs/frontend_notes.md).
  // Neighbours whose depth differs from the point's by more than max_neighbour_depth_ratio
  // of it are the other side of a depth edge and are not used: the default is a surface
  // seen nearly edge-on at Kinect resolution, which is not resolved anyway. A point needs
  // two thirds of its window on its own surface.
  double max_neighbour_depth_ratio = 0.05;
  // ... and its window flat within this many range sigmas (the RMS distance of the window's
  // points from their plane): at a crease or a small object the plane and its normal are
  // not the surface's.
  double max_flatness_sigmas = 3.0;
  // Points on surfaces seen more obliquely than this (angle between the ray and the
  // normal) are left out: their range noise is much larger than sigma_d and their normal
  // poorly defined.
  double max_incidence_deg = 75.0;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<RangeCloudOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct RangeCloud {
  PinholeCamera
      grid;  // the range imager's pinhole on the grid: cell (i, j) is pixel (i step, j step)
  Eigen::Isometry3d T_colour_range = Eigen::Isometry3d::Identity();
  // Row-major, grid.width * grid.height; a point without a valid normal is NaN.
  std::vector<Eigen::Vector3f> p_r;
  std::vector<Eigen::Vector3f> n_r;  // unit normals, facing the camera
  std::vector<float> sigma_m;        // the range noise sigma_d at the point's range
  // A rolling shutter's cloud (MakeRangeCloud's row_motion): p_r and n_r are in the range
  // imager's frame at the frame's timestamp, each moved there from its row's time, and
  // to_row[j] takes a point from that frame into grid row j's, where the grid's pixels see
  // it. Empty for a global shutter.
  std::vector<Eigen::Isometry3f> to_row;

  bool Valid(int index) const { return std::isfinite(p_r[index].x()); }
  int ValidCount() const;
  // The surface where a point in the range imager's frame projects (for a rolling shutter,
  // where it projects from the pose of the row it lands on): the point, normal and
  // range sigma interpolated bilinearly between the four grid points around its projection,
  // so that they move continuously with it (nearest-cell association jumps by a grid cell
  // and keeps an alignment from converging). False when one of the four is invalid or they
  // lie on different surfaces: depths more than max_depth_ratio apart (an edge) or normals
  // that disagree (a crease).
  bool Interpolate(const Eigen::Vector3d& p_r, double max_depth_ratio, Eigen::Vector3d* q_r,
                   Eigen::Vector3d* normal_r, double* sigma) const;
};

// A rolling-shutter frame's motion: the pose, in the range imager's frame at the frame's
// timestamp, of that frame at the time range pixel row `row` was exposed.
using RangeRowMotion = std::function<Eigen::Isometry3d(double row)>;

// The cloud of a range image (CV_32FC1 metres in the range imager's grid, 0 = no
// measurement, as Frame::depth). Throws DataError naming `what` when the image's size does
// not match the imager's. `rays`, when given, are `range`'s (the same cloud, faster).
// `row_motion`, when given, moves each point and normal from its row's time to the frame's
// timestamp (RangeCloud::to_row).
RangeCloud MakeRangeCloud(const cv::Mat& depth, const RangeImager& range,
                          const Eigen::Isometry3d& T_colour_range, const RangeCloudOptions& options,
                          const std::string& what, const RangeRays* rays = nullptr,
                          const RangeRowMotion& row_motion = nullptr);

}  // namespace ieslam
