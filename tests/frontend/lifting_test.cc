#include "frontend/lifting.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/dataset.h"
#include "core/error.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

// Lifting through the offset range imager of the pair set-up
// (frontend/simulation/synthetic_dataset.h: 176x144, 5 cm to the side, turned ~0.5 deg) against the
// exact ray-cast range and against lifting the same pixels through a depth image registered to the
// colour camera.
//
// Tolerance without noise. The lifter returns the range, along the colour ray, of the range
// sample nearest the ray. Samples lie one range pixel (d / f_range) apart across the ray,
// so the nearest is at most half a pixel diagonal (0.71 d / f_range) from it; on a surface
// seen at incidence theta, a lateral offset x changes the range along the ray by
// x tan(theta). Hence |error| <= 0.71 (d / f) tan(theta), plus 0.5 mm for the range
// image's 1 mm quantisation. The registered look-up (median of 3x3 at the colour pixel)
// obeys the same bound with the colour camera's f. With noise, add the range noise:
// 3 sigma(d) covers 99.7% of Gaussian errors.
double GeometricTolerance(double range_m, double cos_incidence, double focal) {
  const double tan_incidence =
      std::sqrt(std::max(0.0, 1.0 - cos_incidence * cos_incidence)) / cos_incidence;
  return 0.71 * range_m / focal * tan_incidence + 0.0005;
}

// The pair rig with its range imager replaced by one registered to the colour camera.
Rig RegisteredAtColour(const Rig& pair) {
  Rig rig = pair;
  rig.registered = true;
  rig.range.camera = pair.colour;
  rig.T_colour_range = Eigen::Isometry3d::Identity();
  return rig;
}

struct PixelTruth {
  Eigen::Vector2d pixel;
  double range_m = 0.0;  // exact distance from the colour camera along the pixel's ray
  double cos_incidence = 1.0;
  // Away from depth edges: one surface within two range pixels around the pixel, seen by
  // the range imager (not hidden from its viewpoint), at incidence below 70 deg (the
  // imager returns nothing beyond 75 deg).
  bool clean = false;
  bool near_edge = false;  // the exact range jumps by > 10 cm within two range pixels
};

struct LiftingCase {
  int trajectory_frame = 0;
  Rig pair;
  std::vector<PixelTruth> truth;  // every third colour pixel inside the range imager's view
  std::vector<LiftedPoint> offset, registered;
};

LiftingCase LiftFrame(int trajectory_frame, bool noise) {
  const SyntheticScene scene{SyntheticSceneOptions()};
  LiftingCase c;
  c.trajectory_frame = trajectory_frame;
  c.pair = SyntheticRig(SyntheticSensor::kPair);
  const Rig registered = RegisteredAtColour(c.pair);
  SyntheticDatasetOptions options;
  options.sensor = SyntheticSensor::kPair;
  options.add_noise = noise;
  const Eigen::Isometry3d T_w_c =
      SyntheticTrajectoryPose(options.trajectory, trajectory_frame, 300);
  const SyntheticFrame frame =
      RenderSyntheticFrame(scene, c.pair, T_w_c, options, trajectory_frame);
  std::mt19937 rng(trajectory_frame);
  const cv::Mat registered_raw = SimulateRangeImage(frame.colour_view, registered.range,
                                                    {options.max_incidence_deg, noise}, &rng);

  const RenderedView& view = frame.colour_view;
  const Eigen::Vector3d range_eye_w = (T_w_c * c.pair.T_colour_range).translation();
  const int reach = static_cast<int>(std::ceil(2.0 * c.pair.colour.fx / c.pair.range.camera.fx));
  std::vector<Eigen::Vector2d> pixels;
  for (int v = 0; v < view.range_m.rows; v += 3) {
    for (int u = 0; u < view.range_m.cols; u += 3) {
      PixelTruth t;
      t.pixel = Eigen::Vector2d(u, v);
      t.range_m = view.range_m.at<double>(v, u);
      t.cos_incidence = view.cos_incidence.at<double>(v, u);
      const Eigen::Vector3d p_c = c.pair.colour.Unproject(t.pixel).normalized() * t.range_m;
      const Eigen::Vector3d p_r = c.pair.T_colour_range.inverse() * p_c;
      if (p_r.z() <= 0.0 || !c.pair.range.camera.InImage(c.pair.range.camera.Project(p_r), 2.0)) {
        continue;
      }
      bool one_surface = true;
      double lo = t.range_m, hi = t.range_m;
      for (int y = std::max(0, v - reach); y <= std::min(view.range_m.rows - 1, v + reach); ++y) {
        for (int x = std::max(0, u - reach); x <= std::min(view.range_m.cols - 1, u + reach); ++x) {
          one_surface = one_surface && view.surface.at<int>(y, x) == view.surface.at<int>(v, u);
          lo = std::min(lo, view.range_m.at<double>(y, x));
          hi = std::max(hi, view.range_m.at<double>(y, x));
        }
      }
      const Eigen::Vector3d p_w = T_w_c * p_c;
      const bool seen_by_range = scene.Intersect(range_eye_w, p_w - range_eye_w).t > 1.0 - 1e-6;
      t.clean = one_surface && seen_by_range && t.cos_incidence > std::cos(70.0 * M_PI / 180.0);
      t.near_edge = hi - lo > 0.1;
      c.truth.push_back(t);
      pixels.push_back(t.pixel);
    }
  }
  c.offset = FeatureLifter(c.pair, LiftingOptions())
                 .Lift(pixels, RangeImageToMetres(frame.range_raw, c.pair.range));
  c.registered = FeatureLifter(registered, LiftingOptions())
                     .Lift(pixels, RangeImageToMetres(registered_raw, registered.range));
  return c;
}

// Two noise-free frames with boxes and boards against the walls, rendered once.
class LiftingTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    for (int trajectory_frame : {150, 220}) {
      noise_free_.push_back(LiftFrame(trajectory_frame, /*noise=*/false));
    }
  }
  static void TearDownTestSuite() { noise_free_.clear(); }
  static std::vector<LiftingCase> noise_free_;
};
std::vector<LiftingCase> LiftingTest::noise_free_;

TEST_F(LiftingTest, OffsetImagerMatchesRegisteredDepthAndTheRayCastAwayFromEdges) {
  for (const LiftingCase& c : noise_free_) {
    SCOPED_TRACE("frame " + std::to_string(c.trajectory_frame));
    const double f_range = c.pair.range.camera.fx, f_colour = c.pair.colour.fx;
    int clean = 0, lifted = 0, registered = 0, off_truth = 0, off_registered = 0;
    for (size_t i = 0; i < c.truth.size(); ++i) {
      const PixelTruth& t = c.truth[i];
      if (!t.clean) continue;
      ++clean;
      registered += c.registered[i].valid;
      if (!c.offset[i].valid) continue;
      ++lifted;
      const double range = c.offset[i].p_c.norm();
      const double tolerance = GeometricTolerance(t.range_m, t.cos_incidence, f_range);
      if (std::abs(range - t.range_m) > tolerance && ++off_truth <= 5) {
        ADD_FAILURE() << "pixel " << t.pixel.transpose() << ": lifted " << range << " m, exact "
                      << t.range_m << " m";
      }
      if (c.registered[i].valid &&
          std::abs(range - c.registered[i].p_c.norm()) >
              tolerance + GeometricTolerance(t.range_m, t.cos_incidence, f_colour)) {
        ++off_registered;
      }
    }
    EXPECT_GT(clean, 25000);
    // Nearly all clean pixels lift through both imagers (docs/frontend_notes.md).
    EXPECT_GT(lifted, 0.99 * clean);
    EXPECT_GT(registered, 0.99 * clean);
    EXPECT_EQ(off_truth, 0);
    EXPECT_EQ(off_registered, 0);
  }
}

// No pixel is lifted onto another surface (by more than the noise model's 3 sigma would even
// allow): those whose ray passes within two range pixels of a depth edge are refused or
// lifted onto their own surface.
TEST_F(LiftingTest, PixelsNearDepthEdgesAreRefusedOrLiftedOntoTheirOwnSurface) {
  int near_edge = 0, lifted = 0, wrong = 0;
  for (const LiftingCase& c : noise_free_) {
    for (size_t i = 0; i < c.truth.size(); ++i) {
      const PixelTruth& t = c.truth[i];
      near_edge += t.near_edge;
      if (!c.offset[i].valid) continue;
      lifted += t.near_edge;
      const double error = std::abs(c.offset[i].p_c.norm() - t.range_m);
      const double allowed =
          GeometricTolerance(t.range_m, t.cos_incidence, c.pair.range.camera.fx) +
          3.0 * c.pair.range.noise.Sigma(t.range_m);
      if (error > allowed && ++wrong <= 5) {
        ADD_FAILURE() << "frame " << c.trajectory_frame << " pixel " << t.pixel.transpose()
                      << ": lifted " << c.offset[i].p_c.norm() << " m, exact " << t.range_m << " m"
                      << (t.near_edge ? " (near an edge)" : "");
      }
    }
  }
  EXPECT_EQ(wrong, 0);
  // The frames have depth edges to test: thousands of sampled pixels near one, hundreds of
  // them lifted, none onto the wrong surface (the counts: docs/frontend_notes.md).
  EXPECT_GT(near_edge, 2000);
  EXPECT_GT(lifted, 200);
}

// With the imager's noise (sigma = 5 mm + 1% of the range), the lifted range is off by the
// noise: within 3 sigma (plus the noise-free bound) for at least 95% of the lifted pixels
// (Gaussian: 99.7%); 99.9% of the pixels away from edges lift.
TEST(LiftingOptionsTest, BadOptionsOrRigThrowConfigError) {
  const Rig rig = SyntheticRig(SyntheticSensor::kPair, 0.25);
  LiftingOptions bad;
  bad.min_valid_in_window = 0;
  EXPECT_THROW(FeatureLifter(rig, bad), ConfigError);
  Rig bad_rig = rig;
  bad_rig.range.max_range_m = 0.0;
  try {
    FeatureLifter lifter(bad_rig, LiftingOptions());
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("synthetic_pair"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(FeatureLifter(rig, LiftingOptions()));
}

TEST(LiftingNoiseTest, NoisyRangesStayWithinThreeSigma) {
  const LiftingCase c = LiftFrame(0, /*noise=*/true);
  int clean = 0, clean_lifted = 0, lifted = 0, within = 0;
  for (size_t i = 0; i < c.truth.size(); ++i) {
    const PixelTruth& t = c.truth[i];
    clean += t.clean;
    if (!c.offset[i].valid) continue;
    clean_lifted += t.clean;
    ++lifted;
    const double error = std::abs(c.offset[i].p_c.norm() - t.range_m);
    within += error <= GeometricTolerance(t.range_m, t.cos_incidence, c.pair.range.camera.fx) +
                           3.0 * c.pair.range.noise.Sigma(t.range_m);
  }
  EXPECT_GT(clean_lifted, 0.98 * clean);
  EXPECT_GT(lifted, 25000);
  EXPECT_GE(within, 0.95 * lifted);
}

}  // namespace
}  // namespace ieslam
