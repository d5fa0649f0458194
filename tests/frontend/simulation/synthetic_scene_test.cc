#include "frontend/simulation/synthetic_scene.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace ieslam {
namespace {

TEST(SyntheticSceneTest, OptionsCheckRejectsBadValues) {
  std::string why;
  EXPECT_TRUE(SyntheticSceneOptions().Check(&why)) << why;
  SyntheticSceneOptions bad;
  bad.room_size_m.z() = 1.0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("room"), std::string::npos) << why;
  bad = SyntheticSceneOptions();
  bad.box_count = -1;
  EXPECT_FALSE(bad.Check(&why));
  bad = SyntheticSceneOptions();
  bad.clear_radii_m.x() = 3.5;  // wider than the 6 m room
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_THROW(SyntheticScene{bad}, ConfigError);
}

TEST(SyntheticSceneTest, SameSeedSameSceneOtherSeedOtherScene) {
  SyntheticSceneOptions options;
  const SyntheticScene a(options), b(options);
  options.seed = 7;
  const SyntheticScene c(options);
  ASSERT_EQ(a.boxes().size(), b.boxes().size());
  for (size_t i = 0; i < a.boxes().size(); ++i) {
    EXPECT_EQ(a.boxes()[i].centre_w, b.boxes()[i].centre_w);
    EXPECT_EQ(a.texture(a.boxes()[i].first_surface).seed,
              b.texture(b.boxes()[i].first_surface).seed);
  }
  ASSERT_FALSE(c.boxes().empty());
  EXPECT_GT((a.boxes()[0].centre_w - c.boxes()[0].centre_w).norm(), 1e-3);
}

TEST(SyntheticSceneTest, ObjectsStandInsideTheRoomOutsideTheClearRegion) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    SyntheticSceneOptions options;
    options.seed = seed;
    const SyntheticScene scene(options);
    // Every box placed (the defaults leave plenty of room), plus the boards.
    EXPECT_EQ(static_cast<int>(scene.boxes().size()), options.box_count) << "seed " << seed;
    EXPECT_EQ(static_cast<int>(scene.boards().size()), options.board_count) << "seed " << seed;
    EXPECT_EQ(scene.surface_count(),
              kRoomSurfaceCount + 6 * options.box_count + options.board_count);
    const Eigen::Vector2d r = options.clear_radii_m;
    for (const SceneBox& box : scene.boxes()) {
      for (int i = 0; i < 8; ++i) {
        const Eigen::Vector3d corner = box.Corner(i);
        EXPECT_TRUE(((corner - scene.room_min_w()).array() >= -1e-9).all()) << corner.transpose();
        EXPECT_TRUE(((scene.room_max_w() - corner).array() >= -1e-9).all()) << corner.transpose();
        EXPECT_GE(std::pow(corner.x() / r.x(), 2) + std::pow(corner.y() / r.y(), 2), 1.0);
      }
      EXPECT_NEAR(box.Corner(0).z(), 0.0, 1e-12);  // standing on the floor
    }
    for (const SceneBoard& board : scene.boards()) {
      const Eigen::Vector3d top = board.origin_w + board.size_v_m * board.axis_v_w;
      EXPECT_NEAR(board.origin_w.z(), 0.0, 1e-12);
      EXPECT_GT(top.z(), 0.5);
      EXPECT_NEAR(board.axis_u_w.dot(board.axis_v_w), 0.0, 1e-12);
    }
  }
}

TEST(SyntheticSceneTest, RaysHitTheRoomPlanesAtTheAnalyticDistance) {
  SyntheticSceneOptions options;
  options.box_count = 0;
  options.board_count = 0;
  const SyntheticScene scene(options);
  const Eigen::Vector3d o(0.3, -0.2, 1.2);
  SceneHit up = scene.Intersect(o, Eigen::Vector3d(0, 0, 2.0));  // t in units of |d| = 2
  EXPECT_EQ(up.surface, kCeiling);
  EXPECT_NEAR(up.t, (3.0 - 1.2) / 2.0, 1e-12);
  EXPECT_NEAR(up.normal_w.z(), -1.0, 1e-12);
  SceneHit down = scene.Intersect(o, Eigen::Vector3d(0, 0, -1.0));
  EXPECT_EQ(down.surface, kFloor);
  EXPECT_NEAR(down.t, 1.2, 1e-12);
  const Eigen::Vector3d d = Eigen::Vector3d(1.0, 0.3, 0.1).normalized();
  const SceneHit wall = scene.Intersect(o, d);
  EXPECT_EQ(wall.surface, kWallPlusX);
  EXPECT_NEAR(wall.t, (3.0 - 0.3) / d.x(), 1e-12);
  EXPECT_NEAR((o + wall.t * d).x(), 3.0, 1e-12);
  // Texture coordinates are the wall's own (y, z) from the room's corner.
  EXPECT_NEAR(wall.st_m.x(), (o + wall.t * d).y() + 2.5, 1e-12);
  EXPECT_NEAR(wall.st_m.y(), (o + wall.t * d).z(), 1e-12);
}

TEST(SyntheticSceneTest, RaysHitTheNearestBoxFaceFromTheRoomSide) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  const Eigen::Vector3d o(0.0, 0.0, 1.0);
  int checked = 0;
  for (const SceneBox& box : scene.boxes()) {
    const Eigen::Vector3d d = box.centre_w - o;
    const SceneHit hit = scene.Intersect(o, d);
    ASSERT_TRUE(hit.valid());
    EXPECT_LT(hit.t, 1.0);  // before the box's centre
    if (hit.surface < box.first_surface || hit.surface >= box.first_surface + 6) continue;
    ++checked;  // not hidden by another box or a board
    // The hit lies on the face's plane: one coordinate in box axes equals +-half size.
    const Eigen::Vector3d p = o + hit.t * d - box.centre_w;
    const double c = std::cos(-box.yaw_rad), s = std::sin(-box.yaw_rad);
    const Eigen::Vector3d local(c * p.x() - s * p.y(), s * p.x() + c * p.y(), p.z());
    const int axis = (hit.surface - box.first_surface) / 2;
    EXPECT_NEAR(std::fabs(local[axis]), box.half_size_m[axis], 1e-9);
    EXPECT_TRUE((local.cwiseAbs() - box.half_size_m).maxCoeff() < 1e-9);
    EXPECT_LT(hit.normal_w.dot(d), 0.0);  // facing the ray's origin
  }
  EXPECT_GE(checked, 5);
}

TEST(SyntheticSceneTest, FreeSpaceExcludesBoxesAndOutside) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  EXPECT_TRUE(scene.IsFreeSpace(Eigen::Vector3d(0, 0, 1.4), 0.3));
  EXPECT_FALSE(scene.IsFreeSpace(Eigen::Vector3d(0, 0, 3.1)));
  EXPECT_FALSE(scene.IsFreeSpace(Eigen::Vector3d(2.9, 0, 1.0), 0.3));
  ASSERT_FALSE(scene.boxes().empty());
  EXPECT_FALSE(scene.IsFreeSpace(scene.boxes()[0].centre_w));
}

}  // namespace
}  // namespace ieslam
