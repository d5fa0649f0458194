#include "frontend/simulation/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <glog/logging.h>
#include <Eigen/Geometry>

#include "core/error.h"

namespace ieslam {
namespace {

constexpr int kPlacementTries = 200;

// Rotation about the vertical by the angle whose cosine and sine are c and s.
Eigen::Vector3d Yaw(double c, double s, const Eigen::Vector3d& v) {
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y(), v.z()};
}

Eigen::Vector3d Yaw(double yaw, const Eigen::Vector3d& v) {
  return Yaw(std::cos(yaw), std::sin(yaw), v);
}

// Wall k of {-x, +x, -y, +y}: its inward normal and the direction along it (horizontal).
Eigen::Vector2d WallInward(int wall) {
  switch (wall) {
    case 0:
      return {1.0, 0.0};
    case 1:
      return {-1.0, 0.0};
    case 2:
      return {0.0, 1.0};
    default:
      return {0.0, -1.0};
  }
}

}  // namespace

bool SyntheticSceneOptions::Check(std::string* why) const {
  std::ostringstream s;
  if (!(room_size_m.minCoeff() >= 2.0) || !room_size_m.allFinite()) {
    s << "room sides must be at least 2 m, got " << room_size_m.transpose();
  } else if (box_count < 0 || box_count > 100) {
    s << "box_count must be in [0, 100], got " << box_count;
  } else if (board_count < 0 || board_count > 50) {
    s << "board_count must be in [0, 50], got " << board_count;
  } else if (!(clear_radii_m.minCoeff() >= 0.0) || !(clear_radii_m.x() < 0.5 * room_size_m.x()) ||
             !(clear_radii_m.y() < 0.5 * room_size_m.y())) {
    s << "clear_radii_m must be non-negative and inside the room, got "
      << clear_radii_m.transpose();
  } else {
    return true;
  }
  if (why != nullptr) *why = s.str();
  return false;
}

Eigen::Vector3d SceneBox::Corner(int i) const {
  const Eigen::Vector3d local((i & 1) ? half_size_m.x() : -half_size_m.x(),
                              (i & 2) ? half_size_m.y() : -half_size_m.y(),
                              (i & 4) ? half_size_m.z() : -half_size_m.z());
  return centre_w + Yaw(yaw_rad, local);
}

SyntheticScene::SyntheticScene(const SyntheticSceneOptions& options) : options_(options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("synthetic scene options: " + why);
  std::mt19937 rng(options.seed);
  for (int i = 0; i < kRoomSurfaceCount; ++i) {
    textures_.push_back(RandomSurfaceTexture(/*allow_text=*/i >= kWallMinusX, &rng));
  }
  PlaceBoxes(&rng);
  PlaceBoards(&rng);
}

Eigen::Vector3d SyntheticScene::room_min_w() const {
  return {-0.5 * options_.room_size_m.x(), -0.5 * options_.room_size_m.y(), 0.0};
}

Eigen::Vector3d SyntheticScene::room_max_w() const {
  return {0.5 * options_.room_size_m.x(), 0.5 * options_.room_size_m.y(), options_.room_size_m.z()};
}

bool SyntheticScene::FootprintIsFree(const Eigen::Vector2d& centre, double radius) const {
  for (const Eigen::Vector3d& other : footprints_) {
    if ((centre - other.head<2>()).norm() < radius + other.z() + 0.05) return false;
  }
  // The clear region: no point of the bounding circle inside the ellipse. Sampling the
  // circle is enough here (the ellipse is far larger than the 5 cm sample spacing matters).
  const Eigen::Vector2d& r = options_.clear_radii_m;
  for (int k = 0; k < 64; ++k) {
    const double a = 2.0 * M_PI * k / 64.0;
    const Eigen::Vector2d p = centre + radius * Eigen::Vector2d(std::cos(a), std::sin(a));
    if (r.minCoeff() > 0.0 && std::pow(p.x() / r.x(), 2) + std::pow(p.y() / r.y(), 2) < 1.0) {
      return false;
    }
  }
  return true;
}

void SyntheticScene::PlaceBoxes(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector2d half_room = 0.5 * options_.room_size_m.head<2>();
  for (int k = 0; k < options_.box_count; ++k) {
    for (int attempt = 0; attempt < kPlacementTries; ++attempt) {
      // The first boxes go round the walls in turn, so that every wall gets some.
      const int wall = attempt == 0 ? k % 4 : static_cast<int>(u(*rng) * 4.0) % 4;
      const Eigen::Vector2d inward = WallInward(wall);
      const Eigen::Vector2d along(-inward.y(), inward.x());
      const double half_wall = wall < 2 ? half_room.y() : half_room.x();
      const double depth_to_wall = wall < 2 ? half_room.x() : half_room.y();
      SceneBox box;
      box.half_size_m = {0.15 + 0.4 * u(*rng), 0.12 + 0.25 * u(*rng), 0.12 + 0.5 * u(*rng)};
      const double radius = box.half_size_m.head<2>().norm();
      const double gap = 0.02 + 0.3 * u(*rng);
      const double offset = (2.0 * u(*rng) - 1.0) * (half_wall - radius - 0.02);
      const Eigen::Vector2d centre =
          -inward * depth_to_wall + inward * (radius + gap) + along * offset;
      box.yaw_rad = std::atan2(along.y(), along.x()) + 0.6 * (u(*rng) - 0.5);
      box.centre_w = {centre.x(), centre.y(), box.half_size_m.z()};
      if (!FootprintIsFree(centre, radius)) continue;
      box.first_surface = static_cast<int>(textures_.size());
      for (int face = 0; face < 6; ++face) {
        textures_.push_back(RandomSurfaceTexture(/*allow_text=*/true, rng));
      }
      footprints_.emplace_back(centre.x(), centre.y(), radius);
      boxes_.push_back(box);
      box_cos_sin_radius2_.emplace_back(std::cos(box.yaw_rad), std::sin(box.yaw_rad),
                                        box.half_size_m.squaredNorm());
      break;
    }
  }
}

void SyntheticScene::PlaceBoards(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector2d half_room = 0.5 * options_.room_size_m.head<2>();
  for (int k = 0; k < options_.board_count; ++k) {
    for (int attempt = 0; attempt < kPlacementTries; ++attempt) {
      const int wall = static_cast<int>(u(*rng) * 4.0) % 4;
      const Eigen::Vector2d inward = WallInward(wall);
      const Eigen::Vector2d along(-inward.y(), inward.x());
      const double half_wall = wall < 2 ? half_room.y() : half_room.x();
      const double depth_to_wall = wall < 2 ? half_room.x() : half_room.y();
      const double width = 0.5 + 0.7 * u(*rng);
      const double length = std::min(0.9 + 0.8 * u(*rng), 0.9 * options_.room_size_m.z());
      const double lean = (8.0 + 17.0 * u(*rng)) * M_PI / 180.0;  // from the vertical
      const double foot = length * std::sin(lean);                // bottom edge to wall
      const double offset = (2.0 * u(*rng) - 1.0) * (half_wall - 0.5 * width - 0.02);
      const Eigen::Vector2d footprint_centre =
          -inward * depth_to_wall + inward * (0.5 * foot + 0.005) + along * offset;
      const double radius = std::hypot(0.5 * width, 0.5 * foot);
      if (!FootprintIsFree(footprint_centre, radius)) continue;
      SceneBoard board;
      const Eigen::Vector2d bottom_left =
          -inward * depth_to_wall + inward * (foot + 0.005) + along * (offset - 0.5 * width);
      board.origin_w = {bottom_left.x(), bottom_left.y(), 0.0};
      board.axis_u_w = {along.x(), along.y(), 0.0};
      board.axis_v_w = {-inward.x() * std::sin(lean), -inward.y() * std::sin(lean), std::cos(lean)};
      board.size_u_m = width;
      board.size_v_m = length;
      board.surface = static_cast<int>(textures_.size());
      textures_.push_back(RandomSurfaceTexture(/*allow_text=*/true, rng));
      footprints_.emplace_back(footprint_centre.x(), footprint_centre.y(), radius);
      boards_.push_back(board);
      break;
    }
  }
}

SceneHit SyntheticScene::Intersect(const Eigen::Vector3d& origin_w,
                                   const Eigen::Vector3d& direction_w, double t_min) const {
  SceneHit hit;
  IntersectRoom(origin_w, direction_w, t_min, &hit);
  IntersectBoxes(origin_w, direction_w, t_min, &hit);
  IntersectBoards(origin_w, direction_w, t_min, &hit);
  return hit;
}

void SyntheticScene::IntersectRoom(const Eigen::Vector3d& origin_w,
                                   const Eigen::Vector3d& direction_w, double t_min,
                                   SceneHit* hit) const {
  // The room from inside: the first of the three slabs the ray leaves.
  const Eigen::Vector3d lo = room_min_w(), hi = room_max_w();
  for (int axis = 0; axis < 3; ++axis) {
    const double d = direction_w[axis];
    if (d == 0.0) continue;
    const bool positive = d > 0.0;
    const double t = ((positive ? hi[axis] : lo[axis]) - origin_w[axis]) / d;
    if (t <= t_min || t >= hit->t) continue;
    hit->t = t;
    hit->surface =
        axis == 2 ? (positive ? kCeiling : kFloor) : kWallMinusX + 2 * axis + (positive ? 1 : 0);
    hit->normal_w = Eigen::Vector3d::Zero();
    hit->normal_w[axis] = positive ? -1.0 : 1.0;
  }
  if (hit->valid()) {
    const Eigen::Vector3d p = origin_w + hit->t * direction_w - lo;
    if (hit->surface == kFloor || hit->surface == kCeiling)
      hit->st_m = {p.x(), p.y()};
    else if (hit->surface <= kWallPlusX)
      hit->st_m = {p.y(), p.z()};
    else
      hit->st_m = {p.x(), p.z()};
  }
}

void SyntheticScene::IntersectBoxes(const Eigen::Vector3d& origin_w,
                                    const Eigen::Vector3d& direction_w, double t_min,
                                    SceneHit* hit) const {
  // Slab test in each box's own axes; the ray enters through the face of the slab entered
  // last.
  const double inverse_length2 = 1.0 / direction_w.squaredNorm();
  for (size_t b = 0; b < boxes_.size(); ++b) {
    const SceneBox& box = boxes_[b];
    const Eigen::Vector3d to_centre = box.centre_w - origin_w;
    const double along = to_centre.dot(direction_w);
    if (to_centre.squaredNorm() - along * along * inverse_length2 > box_cos_sin_radius2_[b].z()) {
      continue;  // the ray's line misses the bounding sphere
    }
    const double c = box_cos_sin_radius2_[b].x(), s = box_cos_sin_radius2_[b].y();
    const Eigen::Vector3d o = Yaw(c, -s, origin_w - box.centre_w);
    const Eigen::Vector3d d = Yaw(c, -s, direction_w);
    double t_near = -std::numeric_limits<double>::infinity();
    double t_far = std::numeric_limits<double>::infinity();
    int entry_axis = -1;
    bool miss = false;
    for (int axis = 0; axis < 3 && !miss; ++axis) {
      const double h = box.half_size_m[axis];
      if (d[axis] == 0.0) {
        miss = std::fabs(o[axis]) > h;
        continue;
      }
      double t0 = (-h - o[axis]) / d[axis], t1 = (h - o[axis]) / d[axis];
      if (t0 > t1) std::swap(t0, t1);
      if (t0 > t_near) {
        t_near = t0;
        entry_axis = axis;
      }
      t_far = std::min(t_far, t1);
      miss = t_near > t_far;
    }
    if (miss || entry_axis < 0 || t_near <= t_min || t_near >= hit->t) continue;
    const bool from_minus = d[entry_axis] > 0.0;  // entering through the -axis face
    Eigen::Vector3d normal_local = Eigen::Vector3d::Zero();
    normal_local[entry_axis] = from_minus ? -1.0 : 1.0;
    const Eigen::Vector3d p = o + t_near * d + box.half_size_m;  // in [0, 2h]
    hit->t = t_near;
    hit->surface = box.first_surface + 2 * entry_axis + (from_minus ? 0 : 1);
    hit->normal_w = Yaw(c, s, normal_local);
    hit->st_m = entry_axis == 0   ? Eigen::Vector2d(p.y(), p.z())
                : entry_axis == 1 ? Eigen::Vector2d(p.x(), p.z())
                                  : Eigen::Vector2d(p.x(), p.y());
  }
}

void SyntheticScene::IntersectBoards(const Eigen::Vector3d& origin_w,
                                     const Eigen::Vector3d& direction_w, double t_min,
                                     SceneHit* hit) const {
  for (const SceneBoard& board : boards_) {
    const Eigen::Vector3d n = board.axis_u_w.cross(board.axis_v_w);
    const double denom = direction_w.dot(n);
    if (std::fabs(denom) < 1e-15) continue;
    const double t = (board.origin_w - origin_w).dot(n) / denom;
    if (t <= t_min || t >= hit->t) continue;
    const Eigen::Vector3d q = origin_w + t * direction_w - board.origin_w;
    const double s = q.dot(board.axis_u_w), v = q.dot(board.axis_v_w);
    if (s < 0.0 || s > board.size_u_m || v < 0.0 || v > board.size_v_m) continue;
    hit->t = t;
    hit->surface = board.surface;
    hit->normal_w = denom < 0.0 ? n : Eigen::Vector3d(-n);
    hit->st_m = {s, v};
  }
}

bool SyntheticScene::IsFreeSpace(const Eigen::Vector3d& p_w, double margin_m) const {
  const Eigen::Vector3d m = Eigen::Vector3d::Constant(margin_m);
  if (((p_w - room_min_w()).array() < m.array()).any() ||
      ((room_max_w() - p_w).array() < m.array()).any()) {
    return false;
  }
  for (const SceneBox& box : boxes_) {
    const Eigen::Vector3d local = Yaw(-box.yaw_rad, p_w - box.centre_w);
    if ((local.cwiseAbs() - box.half_size_m).maxCoeff() < margin_m) return false;
  }
  return true;
}

}  // namespace ieslam
