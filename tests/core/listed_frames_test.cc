#include "core/listed_frames.h"

#include <string>

#include <gtest/gtest.h>

#include "core/dataset_test_files.h"
#include "core/error.h"
#include "core/trajectory.h"

namespace ieslam {
namespace {

TEST(ListedFrames, GroundTruthInterpolatesOrTakesNearest) {
  Trajectory gt(2);
  gt[0].timestamp = 1.0;
  gt[1].timestamp = 1.01;
  gt[1].T_w_c = Eigen::Translation3d(0.1, 0, 0) * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ());
  const auto mid = GroundTruthAt(gt, 1.0025, 0.02);
  ASSERT_TRUE(mid.has_value());
  EXPECT_NEAR(mid->translation().x(), 0.025, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(mid->linear()).angle(), 0.005, 1e-12);
  const auto after = GroundTruthAt(gt, 1.025, 0.02);  // only the last pose is near
  ASSERT_TRUE(after.has_value());
  EXPECT_NEAR(after->translation().x(), 0.1, 1e-12);
  EXPECT_FALSE(GroundTruthAt(gt, 1.05, 0.02).has_value());
  EXPECT_FALSE(GroundTruthAt(gt, 0.9, 0.02).has_value());
}

TEST_F(DatasetFilesTest, ListedFramesPairTheListsAndAttachGroundTruth) {
  // Colour 2.0 has no range image within 0.02 s; range 1.015 is nearer colour 1.0 than 1.1.
  WriteText("c.txt", "# colour\n1.0 c/1.png\n1.1 c/2.png\n2.0 c/3.png\n");
  WriteText("r.txt", "1.015 r/1.png\n1.105 r/2.png\n");
  WriteText("gt.txt", "1.0 0 0 0 0 0 0 1\n1.1 1 0 0 0 0 0 1\n");
  const auto frames = ReadListedFrames(Path("c.txt"), Path("r.txt"), Path("gt.txt"), {});
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].timestamp, 1.0);
  EXPECT_EQ(frames[0].colour_path, Path("c/1.png"));
  EXPECT_EQ(frames[0].depth_path, Path("r/1.png"));
  EXPECT_EQ(frames[1].depth_path, Path("r/2.png"));
  ASSERT_TRUE(frames[1].T_w_c_gt.has_value());
  EXPECT_NEAR(frames[1].T_w_c_gt->translation().x(), 1.0, 1e-12);

  // No ground-truth file: frames without ground truth.
  const auto without = ReadListedFrames(Path("c.txt"), Path("r.txt"), Path("none.txt"), {});
  ASSERT_EQ(without.size(), 2u);
  EXPECT_FALSE(without[0].T_w_c_gt.has_value());
}

TEST_F(DatasetFilesTest, ListedFramesNameTheListThatGivesNoFrames) {
  WriteText("c.txt", "1.0 c/1.png\n");
  WriteText("empty.txt", "# nothing\n");
  WriteText("far.txt", "5.0 r/1.png\n");
  ExpectDataError([&] { ReadListedFrames(Path("c.txt"), Path("empty.txt"), "", {}); },
                  Path("empty.txt"));
  ExpectDataError([&] { ReadListedFrames(Path("c.txt"), Path("far.txt"), "", {}); },
                  Path("far.txt"));
}

}  // namespace
}  // namespace ieslam
