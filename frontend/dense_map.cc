#include "frontend/dense_map.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include <glog/logging.h>

#include "core/error.h"
#include "core/file_util.h"

namespace ieslam {
namespace {

// 21 bits per axis: +-10 km at 1 cm voxels.
int64_t VoxelKey(const Eigen::Vector3d& p, double size) {
  const int64_t offset = int64_t{1} << 20;
  const auto axis = [&](double v) {
    return std::clamp<int64_t>(static_cast<int64_t>(std::floor(v / size)) + offset, 0,
                               (int64_t{1} << 21) - 1);
  };
  return (axis(p.x()) << 42) | (axis(p.y()) << 21) | axis(p.z());
}

}  // namespace

const OptionTable<DenseMapOptions>& DenseMapOptions::Table() {
  static const OptionTable<DenseMapOptions>* table = [] {
    using O = DenseMapOptions;
    auto* t = new OptionTable<O>;
    t->Double("voxel_size_m", &O::voxel_size_m, "map.ply's voxel").Above(0.0);
    t->Int("pixel_step", &O::pixel_step, "every n-th range pixel in each direction").Min(1);
    return t;
  }();
  return *table;
}

DenseMap::DenseMap(const DenseMapOptions& options) : options_(options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
}

void DenseMap::AddFrame(const Frame& frame, const Rig& rig, const Eigen::Isometry3d& T_w_c) {
  AddPoints(FramePoints(frame, rig, T_w_c));
}

void DenseMap::AddPoints(const std::vector<Point>& points) {
  for (const Point& point : points) {
    Voxel& voxel = voxels_[point.voxel];
    voxel.sum += point.p_w;
    for (int i = 0; i < 3; ++i) voxel.colour_sum[i] += point.rgb[i];
    ++voxel.count;
  }
}

std::vector<DenseMap::Point> DenseMap::FramePoints(const Frame& frame, const Rig& rig,
                                                   const Eigen::Isometry3d& T_w_c,
                                                   const RangeRays* rays,
                                                   const RangeRowMotion& row_motion) const {
  CHECK_EQ(frame.depth.type(), CV_32F);
  CHECK_EQ(frame.colour.type(), CV_8UC3);
  const Eigen::Isometry3d T_w_range = T_w_c * rig.T_colour_range;
  std::vector<Point> points;
  for (int y = 0; y < frame.depth.rows; y += options_.pixel_step) {
    const Eigen::Isometry3d T_w_row = row_motion ? T_w_range * row_motion(y) : T_w_range;
    for (int x = 0; x < frame.depth.cols; x += options_.pixel_step) {
      const float value = frame.depth.at<float>(y, x);
      if (!(value > 0.0f) || !std::isfinite(value)) continue;
      const Eigen::Vector3d p_range =
          rays != nullptr ? rays->PixelToPoint(x, y, value) : rig.range.PixelToPoint({x, y}, value);
      const Eigen::Vector3d p_colour = rig.T_colour_range * p_range;
      if (p_colour.z() <= 0.0) continue;
      const Eigen::Vector2d pixel = rig.colour.Project(p_colour);
      if (!rig.colour.InImage(pixel)) continue;
      const cv::Vec3b bgr = frame.colour.at<cv::Vec3b>(static_cast<int>(std::lround(pixel.y())),
                                                       static_cast<int>(std::lround(pixel.x())));
      Point& point = points.emplace_back();
      point.p_w = T_w_row * p_range;
      point.voxel = VoxelKey(point.p_w, options_.voxel_size_m);
      for (int i = 0; i < 3; ++i) point.rgb[i] = bgr[2 - i];
    }
  }
  return points;
}

void DenseMap::WritePly(const std::string& path) const {
  std::vector<int64_t> keys;
  keys.reserve(voxels_.size());
  for (const auto& entry : voxels_) keys.push_back(entry.first);
  std::sort(keys.begin(), keys.end());
  WriteFileAtomically(
      path,
      [&](std::ostream& out) {
        out << "ply\nformat binary_little_endian 1.0\ncomment ieslam dense map\n"
            << "element vertex " << keys.size() << "\n"
            << "property float x\nproperty float y\nproperty float z\n"
            << "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
        char record[15];
        for (int64_t key : keys) {
          const Voxel& v = voxels_.at(key);
          const Eigen::Vector3f p = (v.sum / v.count).cast<float>();
          const Eigen::Vector3d c =
              Eigen::Vector3d(v.colour_sum[0], v.colour_sum[1], v.colour_sum[2]) / v.count;
          std::memcpy(record, p.data(), 12);  // x86-64 and ARM64 are little-endian
          for (int i = 0; i < 3; ++i) {
            record[12 + i] =
                static_cast<char>(static_cast<uint8_t>(std::lround(std::clamp(c[i], 0.0, 255.0))));
          }
          out.write(record, sizeof(record));
        }
      },
      /*binary=*/true);
}

}  // namespace ieslam
