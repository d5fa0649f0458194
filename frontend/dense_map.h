// The paper's dense map: each selected frame's range cloud, coloured from the colour image
// through the calibration, placed at its estimated pose and voxel-filtered (one point per
// occupied voxel: the centroid and mean colour of the points that fell in it).
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>

#include "core/camera.h"
#include "core/dataset.h"
#include "core/option_table.h"
#include "core/range_cloud.h"

namespace ieslam {

struct DenseMapOptions {
  double voxel_size_m = 0.01;
  int pixel_step = 2;  // use every n-th range pixel in each direction

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<DenseMapOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

class DenseMap {
 public:
  explicit DenseMap(const DenseMapOptions& options);

  // A frame's coloured range points in the world, each with its voxel, in pixel order.
  struct Point {
    int64_t voxel = 0;
    Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
    uint8_t rgb[3] = {0, 0, 0};
  };

  // Adds a frame's range cloud at the colour camera pose T_w_c. Range points that the colour
  // camera does not see are left out (they have no colour).
  void AddFrame(const Frame& frame, const Rig& rig, const Eigen::Isometry3d& T_w_c);
  // AddFrame in two steps: the points (const, so callers may compute them on other threads)
  // and their accumulation. Adding frames' points in the same order gives the same map.
  // `rays`, when given, are rig.range's (the same points, faster). `row_motion`, when given,
  // places each point seen at its row's time from the pose of the frame's timestamp (a
  // rolling shutter, core/range_cloud.h).
  std::vector<Point> FramePoints(const Frame& frame, const Rig& rig, const Eigen::Isometry3d& T_w_c,
                                 const RangeRays* rays = nullptr,
                                 const RangeRowMotion& row_motion = nullptr) const;
  void AddPoints(const std::vector<Point>& points);

  size_t size() const { return voxels_.size(); }

  // Binary little-endian PLY (x y z as float, red green blue as uchar), written atomically.
  // Points are sorted by voxel index, so the file does not depend on insertion order.
  void WritePly(const std::string& path) const;

 private:
  // A map holds millions of voxels: colours sum exactly in integers (2^32 / 255 points
  // per voxel before one overflows, far beyond what a voxel receives), in 40 bytes.
  struct Voxel {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    uint32_t colour_sum[3] = {0, 0, 0};  // RGB
    int count = 0;
  };
  DenseMapOptions options_;
  std::unordered_map<int64_t, Voxel> voxels_;
};

}  // namespace ieslam
