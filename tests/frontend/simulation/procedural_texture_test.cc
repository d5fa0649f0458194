#include "frontend/simulation/procedural_texture.h"

#include <gtest/gtest.h>

#include <random>

namespace ieslam {
namespace {

TEST(ProceduralTextureTest, DeterministicBoundedAndNoiseIsContinuous) {
  std::mt19937 rng(3);
  const SurfaceTexture texture = RandomSurfaceTexture(true, &rng);
  std::mt19937 rng2(3);
  EXPECT_EQ(RandomSurfaceTexture(true, &rng2).seed, texture.seed);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector2d st(0.037 * i - 3.0, 0.011 * i);
    const Eigen::Vector3f a = EvaluateTexture(texture, st, 0.004);
    EXPECT_EQ(a, EvaluateTexture(texture, st, 0.004));
    EXPECT_GE(a.minCoeff(), 0.0f);
    EXPECT_LE(a.maxCoeff(), 1.0f);
    const double n = ValueNoise(5, st.x() * 3.0, st.y() * 3.0);
    EXPECT_GE(n, 0.0);
    EXPECT_LE(n, 1.0);
    EXPECT_NEAR(ValueNoise(5, st.x() * 3.0 + 1e-6, st.y() * 3.0), n, 1e-4);
  }
}

// The box filter over the footprint must approximate the average of the texture over that
// footprint far better than sampling it at one point does (the aliasing SIFT would see).
TEST(ProceduralTextureTest, FootprintFilteringApproximatesTheAreaAverage) {
  std::mt19937 rng(11);
  const SurfaceTexture texture = RandomSurfaceTexture(true, &rng);
  for (double w : {0.006, 0.03}) {  // a 640x480 Kinect pixel 3 m and 16 m away
    double filtered_error = 0.0, point_error = 0.0;
    for (int i = 0; i < 300; ++i) {
      const Eigen::Vector2d st(0.0137 * i * 7.0, 0.5 + 0.021 * i);
      Eigen::Vector3f average = Eigen::Vector3f::Zero();
      const int n = 16;
      for (int a = 0; a < n; ++a) {
        for (int b = 0; b < n; ++b) {
          const Eigen::Vector2d offset((a + 0.5) / n - 0.5, (b + 0.5) / n - 0.5);
          average += EvaluateTexture(texture, st + w * offset, w / n);
        }
      }
      average /= static_cast<float>(n * n);
      filtered_error += (EvaluateTexture(texture, st, w) - average).norm();
      point_error += (EvaluateTexture(texture, st, w / n) - average).norm();
    }
    EXPECT_LT(filtered_error, 0.6 * point_error)
        << "w " << w << ": filtered " << filtered_error / 300 << " point " << point_error / 300;
  }
}

}  // namespace
}  // namespace ieslam
