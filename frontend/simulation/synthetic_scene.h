// A synthetic room for rendering RGB-D / camera + range imager data with exact ground truth.
//
// World frame: x and y horizontal, z up (as frontend/simulation/simulation_trajectory.h). The room
// is an axis-aligned box, floor at z = 0, centred on x = y = 0, seen from inside. On the floor
// stand boxes (rotated about the vertical) along the walls, and boards lean against the walls; the
// middle of the room, an elliptic cylinder of radii SyntheticSceneOptions::clear_radii_m, is
// kept free for the camera. Everything is a plane patch, so every depth is exact.
//
// Each face (room side, box side, board) is a surface with its own procedural texture
// (frontend/simulation/procedural_texture.h), looked up in the face's own 2-D coordinates in
// metres. The scene is a pure function of the options (seed included); it holds no mutable state
// and may be queried from many threads at once.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "frontend/simulation/procedural_texture.h"

namespace ieslam {

struct SyntheticSceneOptions {
  Eigen::Vector3d room_size_m{6.0, 5.0, 3.0};  // x, y, z (height)
  int box_count = 10;
  int board_count = 3;  // boards leaning against the walls
  // Horizontal semi-axes (x, y) of the central region no box or board enters.
  Eigen::Vector2d clear_radii_m{1.9, 1.4};
  uint32_t seed = 1;

  bool Check(std::string* why) const;
};

// A box standing on the floor, rotated by yaw about the vertical through its centre.
struct SceneBox {
  Eigen::Vector3d centre_w = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_size_m = Eigen::Vector3d::Ones();  // in the box's own axes
  double yaw_rad = 0.0;
  int first_surface = 0;  // faces -x, +x, -y, +y, -z, +z (box axes) are first_surface + 0..5

  // Corner i (bit 0: +x, bit 1: +y, bit 2: +z in box axes) in the world.
  Eigen::Vector3d Corner(int i) const;
};

// A rectangle origin + s * axis_u + t * axis_v, s in [0, size_u], t in [0, size_v]; seen
// from both sides. Texture coordinates are (s, t).
struct SceneBoard {
  Eigen::Vector3d origin_w = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_u_w = Eigen::Vector3d::UnitX();  // unit
  Eigen::Vector3d axis_v_w = Eigen::Vector3d::UnitZ();  // unit, orthogonal to axis_u
  double size_u_m = 1.0;
  double size_v_m = 1.0;
  int surface = 0;
};

// The nearest intersection of a ray with the scene.
struct SceneHit {
  double t = std::numeric_limits<double>::infinity();  // p_w = origin + t * direction
  int surface = -1;                                    // -1: nothing hit
  Eigen::Vector3d normal_w = Eigen::Vector3d::Zero();  // unit, facing the ray's origin
  Eigen::Vector2d st_m = Eigen::Vector2d::Zero();      // texture coordinates on the surface
  bool valid() const { return surface >= 0; }
};

// Surface indices of the room's faces; boxes and boards follow.
enum RoomSurface : int {
  kFloor = 0,
  kCeiling = 1,
  kWallMinusX = 2,
  kWallPlusX = 3,
  kWallMinusY = 4,
  kWallPlusY = 5,
  kRoomSurfaceCount = 6
};

class SyntheticScene {
 public:
  // Throws ConfigError for options that fail Check(). Boxes and boards that cannot be placed
  // without overlap after many tries are left out (boxes().size() may be below box_count).
  explicit SyntheticScene(const SyntheticSceneOptions& options);

  const SyntheticSceneOptions& options() const { return options_; }
  Eigen::Vector3d room_min_w() const;
  Eigen::Vector3d room_max_w() const;
  const std::vector<SceneBox>& boxes() const { return boxes_; }
  const std::vector<SceneBoard>& boards() const { return boards_; }
  int surface_count() const { return static_cast<int>(textures_.size()); }
  const SurfaceTexture& texture(int surface) const { return textures_.at(surface); }

  // Nearest hit with t > t_min along origin_w + t * direction_w (direction need not be
  // unit; t is then in units of its length). From inside the room every ray hits something.
  SceneHit Intersect(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                     double t_min = 1e-9) const;

  // Surface colour (albedo, before lighting) at a hit, filtered over `footprint_m`.
  Eigen::Vector3f Albedo(const SceneHit& hit, double footprint_m) const {
    return EvaluateTexture(textures_[hit.surface], hit.st_m, footprint_m);
  }

  // True when p_w is inside the room and outside every box (a valid camera position).
  bool IsFreeSpace(const Eigen::Vector3d& p_w, double margin_m = 0.0) const;

 private:
  // The parts of Intersect, in its order: each replaces *hit by a nearer hit (t_min < t <
  // hit->t) on the room's faces, the boxes or the boards.
  void IntersectRoom(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                     double t_min, SceneHit* hit) const;
  void IntersectBoxes(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                      double t_min, SceneHit* hit) const;
  void IntersectBoards(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& direction_w,
                       double t_min, SceneHit* hit) const;
  void PlaceBoxes(std::mt19937* rng);
  void PlaceBoards(std::mt19937* rng);
  bool FootprintIsFree(const Eigen::Vector2d& centre, double radius) const;

  SyntheticSceneOptions options_;
  std::vector<SceneBox> boxes_;
  std::vector<SceneBoard> boards_;
  // Per box: cos and sin of its yaw (Intersect runs per pixel and must not call
  // trigonometry) and the squared radius of its bounding sphere (a quick reject).
  std::vector<Eigen::Vector3d> box_cos_sin_radius2_;
  std::vector<SurfaceTexture> textures_;
  // Horizontal bounding circles (x, y, radius) of what stands on the floor, for placement.
  std::vector<Eigen::Vector3d> footprints_;
};

}  // namespace ieslam
