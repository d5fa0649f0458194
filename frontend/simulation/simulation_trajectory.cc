#include "frontend/simulation/simulation_trajectory.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <glog/logging.h>

#include "core/error.h"

namespace ieslam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

// Camera-to-world rotation of a level camera looking along world +x (z up): camera x
// (right) is world -y, camera y (down) is world -z, camera z (forward) is world +x.
Eigen::Matrix3d LevelCameraRotation() {
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d(0.0, -1.0, 0.0);
  R.col(1) = Eigen::Vector3d(0.0, 0.0, -1.0);
  R.col(2) = Eigen::Vector3d(1.0, 0.0, 0.0);
  return R;
}

// Horizontal corners of one loop, counter-clockwise seen from above, relative to the centre.
std::vector<Eigen::Vector2d> LoopCorners(const PaperTrajectoryOptions& o) {
  std::vector<Eigen::Vector2d> corners;
  if (o.kind == SimulatedTrajectoryKind::kRectangle) {
    const double hx = 0.5 * o.rectangle_length_m;
    const double hy = 0.5 * o.rectangle_width_m;
    corners = {{hx, -hy}, {hx, hy}, {-hx, hy}, {-hx, -hy}};
  } else {
    for (int i = 0; i < o.polygon_sides; ++i) {
      const double theta = 2.0 * kPi * i / o.polygon_sides;
      corners.emplace_back(o.polygon_radius_m * std::cos(theta),
                           o.polygon_radius_m * std::sin(theta));
    }
  }
  return corners;
}

// The polyline of all loops. It starts and ends half-way along the last edge of a loop,
// so that no pose of the first loop sits exactly on a corner. Progress q (in loops) sets
// the slow climb; corners alternate in height on top of it.
std::vector<Eigen::Vector3d> BuildPolyline(const PaperTrajectoryOptions& o) {
  const std::vector<Eigen::Vector2d> corners = LoopCorners(o);
  const int n = static_cast<int>(corners.size());
  auto height = [&](double alternating, double q) {
    return alternating + (q - 0.5 * o.num_loops) * o.height_step_per_loop_m;
  };
  auto alternating = [&](int i) { return (i % 2 == 0 ? 1.0 : -1.0) * o.vertex_height_amplitude_m; };
  const Eigen::Vector2d start_xy = 0.5 * (corners[n - 1] + corners[0]);
  const double start_alternating = 0.5 * (alternating(n - 1) + alternating(0));

  std::vector<Eigen::Vector3d> polyline;
  polyline.emplace_back(start_xy.x(), start_xy.y(), height(start_alternating, 0.0));
  for (int loop = 0; loop < o.num_loops; ++loop) {
    for (int i = 0; i < n; ++i) {
      const double q = loop + (i + 0.5) / n;
      polyline.emplace_back(corners[i].x(), corners[i].y(), height(alternating(i), q));
    }
  }
  polyline.emplace_back(start_xy.x(), start_xy.y(), height(start_alternating, o.num_loops));
  for (Eigen::Vector3d& v : polyline) v += o.centre_m;
  return polyline;
}

}  // namespace

const char* ToString(SimulatedTrajectoryKind kind) {
  return kind == SimulatedTrajectoryKind::kRectangle ? "rectangle" : "polygon";
}

bool PaperTrajectoryOptions::Check(std::string* why) const {
  std::ostringstream s;
  if (num_poses < 2) {
    s << "num_poses must be at least 2, got " << num_poses;
    return Fail(why, s.str());
  }
  if (num_loops < 1) {
    s << "num_loops must be at least 1, got " << num_loops;
    return Fail(why, s.str());
  }
  if (!centre_m.allFinite()) return Fail(why, "centre_m must be finite");
  if (kind == SimulatedTrajectoryKind::kPolygon) {
    if (polygon_sides < 3) {
      s << "polygon_sides must be at least 3, got " << polygon_sides;
      return Fail(why, s.str());
    }
    if (!(polygon_radius_m > 0.0) || !std::isfinite(polygon_radius_m)) {
      s << "polygon_radius_m must be positive and finite, got " << polygon_radius_m;
      return Fail(why, s.str());
    }
  } else if (!(rectangle_length_m > 0.0) || !(rectangle_width_m > 0.0) ||
             !std::isfinite(rectangle_length_m) || !std::isfinite(rectangle_width_m)) {
    s << "rectangle sides must be positive and finite, got " << rectangle_length_m << " x "
      << rectangle_width_m;
    return Fail(why, s.str());
  }
  const double lengths[] = {vertex_height_amplitude_m, height_step_per_loop_m};
  for (double v : lengths) {
    if (!(v >= 0.0) || !std::isfinite(v)) {
      s << "vertex_height_amplitude_m and height_step_per_loop_m must be >= 0 and finite, got "
        << v;
      return Fail(why, s.str());
    }
  }
  if (!(std::abs(look_inward_deg) <= 90.0)) {
    s << "look_inward_deg must be in [-90, 90], got " << look_inward_deg;
    return Fail(why, s.str());
  }
  // Pitch moves beta (rotation about the horizontal camera-right axis); keep it well away
  // from the Euler singularity at 90 deg.
  const double wobbles[] = {yaw_wobble_deg, pitch_wobble_deg, roll_wobble_deg};
  for (double w : wobbles) {
    if (!(w >= 0.0 && w <= 60.0)) {
      s << "wobble amplitudes must be in [0, 60] deg, got " << w;
      return Fail(why, s.str());
    }
  }
  const double cycles[] = {yaw_cycles_per_loop, pitch_cycles_per_loop, roll_cycles_per_loop};
  for (double c : cycles) {
    if (!(c >= 0.0) || !std::isfinite(c)) {
      s << "wobble cycles per loop must be >= 0 and finite, got " << c;
      return Fail(why, s.str());
    }
  }
  return true;
}

PaperTrajectory BuildPaperTrajectory(const PaperTrajectoryOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw ConfigError("PaperTrajectoryOptions: " + why);

  PaperTrajectory trajectory;
  trajectory.vertices = BuildPolyline(o);
  const std::vector<Eigen::Vector3d>& v = trajectory.vertices;
  const int num_segments = static_cast<int>(v.size()) - 1;
  std::vector<double> cumulative(v.size(), 0.0);
  for (int j = 0; j < num_segments; ++j)
    cumulative[j + 1] = cumulative[j] + (v[j + 1] - v[j]).norm();
  trajectory.length_m = cumulative.back();
  trajectory.spacing_m = trajectory.length_m / o.num_poses;
  const double loop_length = trajectory.length_m / o.num_loops;

  const Eigen::Matrix3d R_level = LevelCameraRotation();
  int segment = 0;
  for (int k = 0; k < o.num_poses; ++k) {
    const double s = k * trajectory.spacing_m;
    while (segment + 1 < num_segments && s >= cumulative[segment + 1]) ++segment;
    const double segment_length = cumulative[segment + 1] - cumulative[segment];
    const double t = segment_length > 0.0 ? (s - cumulative[segment]) / segment_length : 0.0;
    const Eigen::Vector3d p = v[segment] + t * (v[segment + 1] - v[segment]);

    // Direction of travel: smooth (tangent of the circle through the current position)
    // for the polygon, the current straight edge for the rectangle.
    double travel_heading = 0.0;
    if (o.kind == SimulatedTrajectoryKind::kRectangle) {
      const Eigen::Vector3d d = v[segment + 1] - v[segment];
      travel_heading = std::atan2(d.y(), d.x());
    } else {
      const Eigen::Vector3d r = p - o.centre_m;
      travel_heading = std::atan2(r.y(), r.x()) + 0.5 * kPi;
    }
    const double phase = 2.0 * kPi * s / loop_length;
    const double yaw = travel_heading + o.look_inward_deg * kDegToRad +
                       o.yaw_wobble_deg * kDegToRad * std::sin(o.yaw_cycles_per_loop * phase);
    // Phase offsets keep the three wobbles from peaking together.
    const double pitch =
        o.pitch_wobble_deg * kDegToRad * std::sin(o.pitch_cycles_per_loop * phase + 1.0);
    const double roll =
        o.roll_wobble_deg * kDegToRad * std::sin(o.roll_cycles_per_loop * phase + 2.0);
    const Eigen::Matrix3d R_w_c =
        Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_level *
        Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()).toRotationMatrix() *
        Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();

    Vector6d T_w_c;
    T_w_c << p, RotationToEulerZyx(R_w_c);
    trajectory.T_w_c.push_back(T_w_c);
  }

  // The first pose at or past each interior vertex.
  for (int j = 1; j < num_segments; ++j) {
    const int k = static_cast<int>(std::ceil(cumulative[j] / trajectory.spacing_m - 1e-9));
    if (k < o.num_poses) trajectory.corner_poses.push_back(k);
  }
  return trajectory;
}

double CameraHeading(const Vector6d& T_w_c) {
  const Eigen::Vector3d forward = EulerZyxToRotation(T_w_c.tail<3>()).col(2);
  return std::atan2(forward.y(), forward.x());
}

}  // namespace ieslam
