#include "core/range_cloud.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "core/error.h"

namespace ieslam {

namespace {

// The cloud of `range`'s grid at `step` with every point, normal and sigma NaN.
RangeCloud EmptyRangeCloud(const RangeImager& range, const Eigen::Isometry3d& T_colour_range,
                           int step) {
  RangeCloud cloud;
  cloud.T_colour_range = T_colour_range;
  cloud.grid = range.camera;
  cloud.grid.width = (range.camera.width + step - 1) / step;
  cloud.grid.height = (range.camera.height + step - 1) / step;
  cloud.grid.fx /= step;
  cloud.grid.fy /= step;
  cloud.grid.cx /= step;
  cloud.grid.cy /= step;
  const size_t cells = static_cast<size_t>(cloud.grid.width) * cloud.grid.height;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud.p_r.assign(cells, Eigen::Vector3f::Constant(nan));
  cloud.n_r.assign(cells, Eigen::Vector3f::Constant(nan));
  cloud.sigma_m.assign(cells, nan);
  return cloud;
}

// A grid point's position, normal and range sigma from the range pixels of its window
// (RangeCloudOptions says which are used and when the point is refused).
class GridPointEstimator {
 public:
  GridPointEstimator(const cv::Mat& depth, const RangeImager& range, const RangeRays* rays,
                     const RangeCloudOptions& options, const std::string& what)
      : depth_(depth),
        range_(range),
        rays_(rays),
        options_(options),
        what_(what),
        radius_(options.step),
        stride_(std::max(1, options.step / 2)),
        per_row_(2 * (radius_ / stride_) + 1),
        window_(per_row_ * per_row_),
        min_cos_incidence_(std::cos(options.max_incidence_deg * M_PI / 180.0)) {}

  // The point at pixel (x, y), its unit normal facing the camera and its sigma; false when
  // the pixel or its window does not make a point. Throws ConfigError naming `what` when the
  // noise model gives a sigma that is not positive.
  bool Estimate(int x, int y, Eigen::Vector3d* p_out, Eigen::Vector3d* n_out,
                double* sigma_out) const {
    Eigen::Vector3d p;
    if (!PointAt(x, y, 0.0, &p)) return false;
    // The window's plane: centroid and scatter about it (relative to p, for precision).
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    int count = 0;
    const int reach = (radius_ / stride_) * stride_;  // symmetric for any step
    for (int dy = -reach; dy <= reach; dy += stride_) {
      for (int dx = -reach; dx <= reach; dx += stride_) {
        Eigen::Vector3d q;
        if (!PointAt(x + dx, y + dy, p.z(), &q)) continue;
        const Eigen::Vector3d d = q - p;
        sum += d;
        scatter.noalias() += d * d.transpose();
        ++count;
      }
    }
    if (3 * count < 2 * window_) return false;
    const Eigen::Vector3d mean = sum / count;
    const Eigen::Matrix3d covariance = scatter / count - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
    eigen.computeDirect(covariance);
    const double sigma = range_.noise.Sigma(p.norm());
    if (!(sigma > 0.0)) {
      throw ConfigError(what_ + ": the range noise model gives sigma " + std::to_string(sigma) +
                        " m at " + std::to_string(p.norm()) + " m; it must be positive");
    }
    const double off_plane = std::sqrt(std::max(0.0, eigen.eigenvalues()[0]));
    if (off_plane > options_.max_flatness_sigmas * sigma) return false;
    Eigen::Vector3d n = eigen.eigenvectors().col(0).normalized();
    const Eigen::Vector3d ray = p.normalized();
    if (n.dot(ray) > 0.0) n = -n;
    if (-n.dot(ray) < min_cos_incidence_) return false;
    *p_out = p;
    *n_out = n;
    *sigma_out = sigma;
    return true;
  }

 private:
  // The point at a pixel, or nothing when its range is invalid or too far from `z0`'s.
  bool PointAt(int x, int y, double z0, Eigen::Vector3d* p) const {
    if (x < 0 || y < 0 || x >= depth_.cols || y >= depth_.rows) return false;
    const float value = depth_.at<float>(y, x);
    if (!(value > 0.0f) || !std::isfinite(value)) return false;
    *p = rays_ != nullptr ? rays_->PixelToPoint(x, y, value)
                          : range_.PixelToPoint(Eigen::Vector2d(x, y), value);
    return z0 <= 0.0 || std::abs(p->z() - z0) <= options_.max_neighbour_depth_ratio * z0;
  }

  const cv::Mat& depth_;
  const RangeImager& range_;
  const RangeRays* rays_;
  const RangeCloudOptions& options_;
  const std::string& what_;
  const int radius_;
  const int stride_;
  const int per_row_;  // the window's offsets in each direction
  const int window_;
  const double min_cos_incidence_;
};

// The grid row nearest to y, clamped to the grid (0 for NaN): std::lround clamped, up to the
// last bit at halves, and inline, because it runs for every point of every dense alignment.
int NearestRow(double y, int height) {
  if (!(y > 0.0)) return 0;
  if (!(y < height - 1)) return height - 1;
  return static_cast<int>(y + 0.5);
}

}  // namespace

const OptionTable<RangeCloudOptions>& RangeCloudOptions::Table() {
  static const OptionTable<RangeCloudOptions>* table = [] {
    using O = RangeCloudOptions;
    auto* t = new OptionTable<O>;
    t->Int("grid_step", &O::step, "range pixels between cloud points").Range(1, 64);
    t->Double("max_neighbour_depth_ratio", &O::max_neighbour_depth_ratio,
              "normals: neighbours within this share of the point's depth")
        .Above(0.0);
    t->Double("max_flatness_sigmas", &O::max_flatness_sigmas,
              "normals: the window flat within this many range sigmas")
        .Above(0.0);
    t->Double("max_incidence_deg", &O::max_incidence_deg,
              "surfaces seen more obliquely are left out")
        .Above(0.0)
        .Below(90.0);
    return t;
  }();
  return *table;
}

int RangeCloud::ValidCount() const {
  int count = 0;
  for (size_t i = 0; i < p_r.size(); ++i) count += Valid(static_cast<int>(i)) ? 1 : 0;
  return count;
}

bool RangeCloud::Interpolate(const Eigen::Vector3d& p, double max_depth_ratio, Eigen::Vector3d* q_r,
                             Eigen::Vector3d* normal_r, double* sigma) const {
  if (!(p.z() > 0.0)) return false;
  Eigen::Vector2d cell = grid.Project(p);
  if (!to_row.empty()) {
    // The row p lands on, seen from that row's pose: the rows' poses differ little, so two
    // rounds settle it (one when the first lands on the row it started from).
    int previous_row = -1;
    for (int round = 0; round < 2; ++round) {
      const int row = NearestRow(cell.y(), grid.height);
      if (row == previous_row) break;
      previous_row = row;
      const Eigen::Vector3d p_row = to_row[row].cast<double>() * p;
      if (!(p_row.z() > 0.0)) return false;
      cell = grid.Project(p_row);
    }
  }
  const double fx = std::floor(cell.x()), fy = std::floor(cell.y());
  if (!(fx >= 0.0 && fy >= 0.0 && fx + 1.0 < grid.width && fy + 1.0 < grid.height)) return false;
  const int x = static_cast<int>(fx), y = static_cast<int>(fy);
  const double ax = cell.x() - fx, ay = cell.y() - fy;
  const int corner[4] = {y * grid.width + x, y * grid.width + x + 1, (y + 1) * grid.width + x,
                         (y + 1) * grid.width + x + 1};
  const double weight[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
  Eigen::Vector3d q = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
  double s = 0.0, z_min = std::numeric_limits<double>::infinity(), z_max = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (!Valid(corner[k])) return false;
    const double z = p_r[corner[k]].z();
    z_min = std::min(z_min, z);
    z_max = std::max(z_max, z);
    q += weight[k] * p_r[corner[k]].cast<double>();
    n += weight[k] * n_r[corner[k]].cast<double>();
    s += weight[k] * sigma_m[corner[k]];
  }
  // Normals that disagree (their mean shorter than cos 18 deg) straddle a crease, where the
  // bilinear patch is a bevel that is neither surface.
  const double n_norm = n.norm();
  if (z_max - z_min > max_depth_ratio * z_min || !(n_norm > 0.95)) return false;
  *q_r = q;
  *normal_r = n / n_norm;  // n.normalized(), without its second square root
  *sigma = s;
  return true;
}

RangeCloud MakeRangeCloud(const cv::Mat& depth, const RangeImager& range,
                          const Eigen::Isometry3d& T_colour_range, const RangeCloudOptions& options,
                          const std::string& what, const RangeRays* rays,
                          const RangeRowMotion& row_motion) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  if (depth.type() != CV_32FC1 || depth.cols != range.camera.width ||
      depth.rows != range.camera.height) {
    throw DataError(what + ": range image is " + std::to_string(depth.cols) + "x" +
                    std::to_string(depth.rows) + ", expected " +
                    std::to_string(range.camera.width) + "x" + std::to_string(range.camera.height) +
                    " metres (CV_32FC1)");
  }
  const int step = options.step;
  RangeCloud cloud = EmptyRangeCloud(range, T_colour_range, step);
  const GridPointEstimator estimator(depth, range, rays, options, what);
  for (int gy = 0; gy < cloud.grid.height; ++gy) {
    Eigen::Isometry3d to_frame = Eigen::Isometry3d::Identity();
    if (row_motion) {
      to_frame = row_motion(gy * step);
      cloud.to_row.push_back(to_frame.inverse().cast<float>());
    }
    for (int gx = 0; gx < cloud.grid.width; ++gx) {
      Eigen::Vector3d p, n;
      double sigma = 0.0;
      if (!estimator.Estimate(gx * step, gy * step, &p, &n, &sigma)) continue;
      const size_t cell = static_cast<size_t>(gy) * cloud.grid.width + gx;
      cloud.p_r[cell] = (to_frame * p).cast<float>();
      cloud.n_r[cell] = (to_frame.linear() * n).cast<float>();
      cloud.sigma_m[cell] = static_cast<float>(sigma);
    }
  }
  return cloud;
}

}  // namespace ieslam
