#include "selection/keyframe_selector.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "backend/evaluation/evaluation.h"
#include "frontend/simulation/known_association_source.h"
#include "frontend/simulation/paper_simulation.h"
#include "short_paper_simulation.h"

namespace ieslam {
namespace {

using testing_selection::ShortPaperSimulation;

SelectorOptions Kind(SelectorKind kind) {
  SelectorOptions options;
  options.kind = kind;
  return options;
}

// The selector over the simulation's frames into a filter, the first pose at the truth.
struct SelectorRun {
  SelectionResult selection;
  std::unique_ptr<InformationFilter> filter;
  int frames_used() const { return static_cast<int>(selection.selected.size()); }
};

SelectorRun RunSelector(const SimulatedDataset& data, const SelectorOptions& options) {
  std::vector<double> timestamps(data.num_poses());
  for (int k = 0; k < data.num_poses(); ++k) timestamps[k] = k;
  KnownAssociationSource source(data.observations, timestamps, data.camera,
                                PoseToIsometry(data.T_w_c_true[0]), options.min_common_features);
  SelectorRun run;
  run.filter = std::make_unique<InformationFilter>(InformationFilterOptions(), data.camera);
  run.selection = KeyframeSelector(options).Run(&source, run.filter.get());
  return run;
}

// The selected poses' ATE against the truth (timestamps: pose indices).
double Ate(const SelectorRun& run, const SimulatedDataset& data) {
  Trajectory truth, estimate;
  std::vector<int> frames = run.selection.selected;
  std::sort(frames.begin(), frames.end());
  for (const int frame : frames) {
    estimate.push_back({static_cast<double>(frame), PoseToIsometry(run.filter->pose(frame))});
    truth.push_back({static_cast<double>(frame), PoseToIsometry(data.T_w_c_true[frame])});
  }
  return ComputeAte(truth, estimate, EvaluationOptions()).translation.rmse;
}

Vector6d PoseError(const SelectorRun& run, const SimulatedDataset& data, int frame) {
  return PoseDifference(run.filter->pose(frame), data.T_w_c_true[frame]);
}

TEST(KeyframeSelectorTest, NoiseFreeAllFramesFilterRecoversTheTruth) {
  const SimulatedDataset data = ShortPaperSimulation(false);
  const SelectorRun m = RunSelector(data, Kind(SelectorKind::kAll));
  EXPECT_EQ(m.frames_used(), 80);
  for (const int frame : m.selection.selected) {
    const Vector6d error = PoseError(m, data, frame);
    EXPECT_LT(error.head<3>().norm(), 1e-6) << "frame " << frame;
    EXPECT_LT(error.tail<3>().norm(), 1e-6) << "frame " << frame;
  }
}

TEST(KeyframeSelectorTest, InfoSelectorUsesFewerFramesAndRecordsEveryDecision) {
  const SimulatedDataset data = ShortPaperSimulation(true);
  const SelectorRun m = RunSelector(data, Kind(SelectorKind::kInfo));
  EXPECT_LT(m.frames_used(), 80);
  EXPECT_GT(m.frames_used(), 80 / 3 - 1);  // a buffer of 3 adds at least every third frame
  // Selected frames increase, and each decision's added frames are among its candidates.
  for (size_t i = 1; i < m.selection.selected.size(); ++i) {
    EXPECT_LT(m.selection.selected[i - 1], m.selection.selected[i]);
  }
  int added = 0;
  for (const SelectionDecision& d : m.selection.decisions) {
    EXPECT_FALSE(d.reason.empty());
    if (d.reason == "best_gain" || d.reason == "threshold") {
      EXPECT_EQ(d.gains.size(), d.candidates.size());  // every candidate of a buffer is scored
    }
    for (int f : d.added) {
      EXPECT_NE(std::find(d.candidates.begin(), d.candidates.end(), f), d.candidates.end());
    }
    added += static_cast<int>(d.added.size());
  }
  EXPECT_EQ(added, m.frames_used());
  // Every frame is placed: selected, or registered to a base frame.
  for (const FramePlacement& p : m.selection.frames) EXPECT_TRUE(p.placed) << "frame " << p.frame;
  EXPECT_LT(Ate(m, data), 0.05);
}

TEST(KeyframeSelectorTest, IntervalSelectsEveryNthFrame) {
  const SimulatedDataset data = ShortPaperSimulation(true);
  SelectorOptions options = Kind(SelectorKind::kInterval);
  options.interval = 4;
  const SelectorRun m = RunSelector(data, options);
  ASSERT_EQ(m.frames_used(), 20);
  for (size_t i = 0; i < m.selection.selected.size(); ++i)
    EXPECT_EQ(m.selection.selected[i], 4 * static_cast<int>(i));
}

TEST(KeyframeSelectorTest, DeadReckoningDriftsMoreThanTheFilter) {
  const SimulatedDataset data = ShortPaperSimulation(true);
  const SelectorRun filtered = RunSelector(data, Kind(SelectorKind::kAll));
  const double filtered_error =
      PoseError(filtered, data, filtered.selection.selected.back()).head<3>().norm();
  std::vector<double> timestamps(data.observations.size());
  KnownAssociationSource source(data.observations, timestamps, data.camera,
                                PoseToIsometry(data.T_w_c_true[0]));
  const SelectionResult chained =
      KeyframeSelector(Kind(SelectorKind::kDeadReckoning)).Run(&source, nullptr);
  ASSERT_EQ(chained.chained_T_w_c.size(), data.observations.size());
  const Eigen::Vector3d last_true = data.T_w_c_true.back().head<3>();
  const double chained_error = (chained.chained_T_w_c.back().translation() - last_true).norm();
  EXPECT_GT(chained_error, 2.0 * filtered_error);
}

// A frame becomes a candidate only when it changes the view enough from the previous one:
// with the threshold at 2.5 times the trajectory's typical per-frame rotation, candidates are
// at least two frames apart, fewer frames enter the filter, and every frame is still placed.
TEST(KeyframeSelectorTest, CandidatesNeedAViewChangeAndTheFramesBetweenArePlaced) {
  const SimulatedDataset data = ShortPaperSimulation(true);
  std::vector<double> per_frame;
  for (size_t k = 1; k < data.T_w_c_true.size(); ++k) {
    const Eigen::Isometry3d T =
        PoseToIsometry(data.T_w_c_true[k - 1]).inverse() * PoseToIsometry(data.T_w_c_true[k]);
    per_frame.push_back(Eigen::AngleAxisd(T.linear()).angle() * 180.0 / M_PI);
  }
  std::sort(per_frame.begin(), per_frame.end());
  const double typical = per_frame[per_frame.size() / 2];
  ASSERT_GT(typical, 0.1);
  auto run = [&](double min_view_change_deg) {
    SelectorOptions options = Kind(SelectorKind::kInfo);
    options.min_view_change_deg = min_view_change_deg;
    return RunSelector(data, options);
  };
  const SelectorRun every = run(0.0);
  const SelectorRun spaced = run(2.5 * typical);
  EXPECT_LT(spaced.frames_used(), every.frames_used());
  int gaps = 0, wide = 0;
  for (const SelectionDecision& d : spaced.selection.decisions) {
    for (size_t k = 1; k < d.candidates.size(); ++k, ++gaps) {
      if (d.candidates[k] - d.candidates[k - 1] >= 2) ++wide;
    }
  }
  ASSERT_GT(gaps, 10);
  EXPECT_GT(wide, 0.8 * gaps);  // the rotation varies along the trajectory
  for (const FramePlacement& p : spaced.selection.frames)
    EXPECT_TRUE(p.placed) << "frame " << p.frame;
  EXPECT_LT(Ate(spaced, data), 0.05);
  SelectorOptions bad;
  bad.min_view_change_deg = -1.0;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("min_view_change_deg"), std::string::npos);
}

TEST(KeyframeSelectorTest, OptionsAreChecked) {
  SelectorOptions options;
  std::string why;
  EXPECT_TRUE(options.Check(&why));
  options.buffer_size = -4;
  EXPECT_FALSE(options.Check(&why));
  EXPECT_NE(why.find("-4"), std::string::npos);
  SelectorKind kind;
  EXPECT_TRUE(ParseSelectorKind("deadreckoning", &kind));
  EXPECT_EQ(SelectorKindName(kind), "deadreckoning");
  EXPECT_FALSE(ParseSelectorKind("greedy", &kind));
}

}  // namespace
}  // namespace ieslam

namespace ieslam {
namespace {

// Selected frames per pose in the neighbourhoods `near` against the rest of the sequence.
std::pair<double, double> SelectionDensity(const SelectionResult& selection,
                                           const std::vector<bool>& near) {
  double in = 0, in_total = 0, out = 0, out_total = 0;
  for (const FramePlacement& p : selection.frames) {
    (near[p.frame] ? in_total : out_total) += 1;
    if (p.selected) (near[p.frame] ? in : out) += 1;
  }
  return {in / in_total, out / out_total};
}

TEST(KeyframeSelectorTest, SelectsMoreFramesAtSharpTurnsThanOnStraightStretches) {
  SimulationOptions options;
  options.trajectory.kind = SimulatedTrajectoryKind::kRectangle;
  options.trajectory.num_poses = 150;
  options.trajectory.num_loops = 1;
  const SimulatedDataset data = SimulatePaperScenario(options);
  SelectorOptions selector;
  selector.buffer_size = 5;
  const SelectorRun m = RunSelector(data, selector);
  std::vector<bool> near_corner(data.num_poses(), false);
  for (int corner : data.corner_poses) {
    for (int k = std::max(0, corner - 3); k <= std::min(data.num_poses() - 1, corner + 3); ++k) {
      near_corner[k] = true;
    }
  }
  const auto [at_turns, straight] = SelectionDensity(m.selection, near_corner);
  EXPECT_GT(at_turns, 1.5 * straight) << "turns " << at_turns << " straight " << straight;
}

TEST(KeyframeSelectorTest, SelectsMoreFramesInAFeaturePoorStretch) {
  SimulationOptions options;
  options.trajectory.num_poses = 150;
  options.trajectory.num_loops = 1;
  options.feature_poor_start = 0.4;
  options.feature_poor_length = 0.2;
  const SimulatedDataset data = SimulatePaperScenario(options);
  SelectorOptions selector;
  selector.buffer_size = 5;
  const SelectorRun m = RunSelector(data, selector);
  const auto [poor, rich] = SelectionDensity(m.selection, data.in_feature_poor_stretch);
  EXPECT_GT(poor, 1.5 * rich) << "feature-poor " << poor << " feature-rich " << rich;
}

}  // namespace
}  // namespace ieslam
