// The paper's dense map: each selected frame's range cloud, coloured from the colour image
// through the calibration, placed at its estimated pose and voxel-filtered (one point per
// occupied voxel: the centroid and mean colour of the points that fell in it).
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>

#include <Eigen/Geometry>

#include "core/camera.h"
#include "core/dataset.h"
#include "core/option_table.h"

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

  // Adds a frame's range cloud at the colour camera pose T_w_c. Range points that the colour
  // camera does not see are left out (they have no colour).
  void AddFrame(const Frame& frame, const Rig& rig, const Eigen::Isometry3d& T_w_c);

  size_t size() const { return voxels_.size(); }

  // Binary little-endian PLY (x y z as float, red green blue as uchar), written atomically.
  // Points are sorted by voxel index, so the file does not depend on insertion order.
  void WritePly(const std::string& path) const;

 private:
  struct Voxel {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Vector3d colour_sum = Eigen::Vector3d::Zero();  // RGB
    int count = 0;
  };
  DenseMapOptions options_;
  std::unordered_map<int64_t, Voxel> voxels_;
};

}  // namespace ieslam
