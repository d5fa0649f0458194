// Speed of the sparse EIF (backend/information_filter.h): one update + state recovery at the
// paper's sizes, the whole all-frames simulation, the growth of the cost with the number of
// poses, and the joint feature covariance the frame selector asks for once per buffer.
//
// Two kinds of problem, both with the paper's statistics (~100 (u, v, d) observations per
// pose, every feature seen from tens of poses):
//  - the paper's simulation (frontend/simulation/paper_simulation.h): two loops through one
//    volume, so the second loop re-observes the first loop's features and the pose block of
//    the factor fills in completely -- the hard case;
//  - a corridor: a camera sliding along a long box of features, never coming back, so the
//    factor stays banded -- the case where the size can grow to 50,000 variables.
// Each benchmark loads its frames with deferred recovery (one factorisation), then times
// ordinary AddPose calls, each one a full EIF update + recovery. Up to 400 poses the filter
// factors through its dense pose Schur complement (InformationFilterOptions::
// max_dense_pose_dim); the _SparseOnly variants time the sparse CHOLMOD factor instead, the
// _ExactRecovery ones refactor at every update. docs/filter_internals.md has what these
// measured.
//
// Run: build with -DIESLAM_BUILD_BENCHMARKS=ON, then
//   ieslam_bench --benchmark_filter=InformationFilter
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include <benchmark/benchmark.h>

#include "backend/information_filter.h"
#include "frontend/simulation/paper_simulation.h"

namespace ieslam {
namespace {

struct Problem {
  PinholeCamera camera;
  std::vector<Vector6d> poses;  // initial values given to the filter (the truth here)
  std::vector<std::vector<FeatureObservation>> observations;
};

Problem PaperProblem(int feature_count, int num_poses = 300) {
  SimulationOptions options;
  options.feature_count = feature_count;
  options.trajectory.num_poses = num_poses;
  const SimulatedDataset data = SimulatePaperScenario(options);
  return {data.camera, data.T_w_c_true, data.observations};
}

// A camera sliding sideways along x, 0.23 m a step, with a little random rotation, through
// a 4 m x 5 m (y, depth) box holding 19 features a metre: ~100 features in view, each seen
// from ~25 consecutive poses, ~19 state dimensions a pose.
Problem CorridorProblem(int num_poses) {
  constexpr double kStep = 0.23, kFeaturesPerMetre = 19.0;
  Problem problem;
  problem.camera = PaperSimulationCamera();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> y(-2.0, 2.0), depth(2.0, 7.0), wobble(-0.05, 0.05);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double length = kStep * num_poses + 6.0;
  std::uniform_real_distribution<double> x(-3.0, length - 3.0);
  std::vector<Eigen::Vector3d> points(static_cast<size_t>(kFeaturesPerMetre * length));
  for (Eigen::Vector3d& p : points) p = Eigen::Vector3d(x(rng), y(rng), depth(rng));
  std::sort(points.begin(), points.end(),
            [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.x() < b.x(); });
  for (int i = 0; i < num_poses; ++i) {
    Vector6d T_w_c;
    T_w_c << kStep * i, 0.0, 0.0, wobble(rng), wobble(rng), wobble(rng);
    problem.poses.push_back(T_w_c);
    std::vector<FeatureObservation> observations;
    for (size_t j = 0; j < points.size(); ++j) {
      if (std::abs(points[j].x() - T_w_c.x()) > 6.0) continue;
      if (!IsFeatureVisible(T_w_c, points[j], problem.camera, 0.3, 7.5)) continue;
      FeatureObservation obs;
      obs.feature_id = static_cast<int64_t>(j);
      obs.z = PredictObservation(T_w_c, points[j], problem.camera);
      const Eigen::Vector3d sigma(1.0, 1.0, 0.005 + 0.01 * obs.z.z());
      obs.Q = sigma.cwiseAbs2().asDiagonal();
      obs.z += sigma.cwiseProduct(Eigen::Vector3d(normal(rng), normal(rng), normal(rng)));
      observations.push_back(obs);
    }
    problem.observations.push_back(observations);
  }
  return problem;
}

// Loads the first `count` frames with one factorisation at the end.
void Load(const Problem& problem, int count, InformationFilter* filter) {
  filter->set_defer_recovery(true);
  filter->AddFirstPose(0, problem.poses[0], problem.observations[0]);
  for (int i = 1; i < count; ++i) filter->AddPose(i, problem.poses[i], problem.observations[i]);
  filter->set_defer_recovery(false);
  filter->Recover();
}

// Initial value as a registration would give it: the previous pose's estimate moved by
// the true relative motion (the estimate drifts from the truth, and the features with it).
void AddNext(const Problem& problem, int next, InformationFilter* filter) {
  const Vector6d initial = filter->pose(next - 1) + (problem.poses[next] - problem.poses[next - 1]);
  filter->AddPose(next, initial, problem.observations[next]);
}

constexpr int kWarmUpdates = 8;

// The paper's filter, every feature in the state from its first sighting: what the
// figures of docs/filter_internals.md were measured on, and what these problems' candidates
// are scored against (their covariance holds the known features only).
InformationFilterOptions PaperOptions() {
  InformationFilterOptions options;
  options.min_sightings = 1;
  return options;
}

// Times `state.iterations()` AddPose calls ending at frame `end`. The first frames are
// loaded in one go, then kWarmUpdates untimed updates bring the factor to its usual state
// between two full factorisations (recent variables last, updated in place).
void TimeUpdates(const Problem& problem, int end, benchmark::State& state,
                 const InformationFilterOptions& options = PaperOptions()) {
  const int timed = static_cast<int>(state.max_iterations);
  InformationFilter filter(options, problem.camera);
  Load(problem, end - timed - kWarmUpdates, &filter);
  int next = end - timed - kWarmUpdates;
  for (; next < end - timed; ++next) AddNext(problem, next, &filter);
  double analyze = 0.0, factorize = 0.0, solve = 0.0, slowest = 0.0;
  int cg_iterations = 0;
  for (auto _ : state) {
    AddNext(problem, next, &filter);
    ++next;
    analyze += filter.last_timings().analyze_s;
    factorize += filter.last_timings().factorize_s;
    solve += filter.last_timings().solve_s;
    slowest = std::max(slowest, filter.last_timings().total_s);
    cg_iterations += filter.last_timings().cg_iterations;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["state_dim"] = filter.state_dim();
  state.counters["poses"] = filter.num_poses();
  state.counters["factor_nnz"] = static_cast<double>(filter.FactorNonzeros());
  state.counters["analyze_ms"] = 1e3 * analyze / n;
  state.counters["factorize_ms"] = 1e3 * factorize / n;
  state.counters["solve_ms"] = 1e3 * solve / n;
  state.counters["max_ms"] = 1e3 * slowest;
  state.counters["cg_iterations"] = cg_iterations / n;
  state.counters["dense_schur"] = filter.uses_pose_schur() ? 1 : 0;
}

// The sparse factor only (no dense pose Schur complement), for comparison.
InformationFilterOptions SparseOnly() {
  InformationFilterOptions options = PaperOptions();
  options.max_dense_pose_dim = 0;
  return options;
}

// The exact factor on every update (no conjugate gradients), for comparison.
InformationFilterOptions ExactRecovery() {
  InformationFilterOptions options = PaperOptions();
  options.iterative_recovery = false;
  return options;
}

constexpr int kTimedUpdates = 4;

// The paper's simulation with more features (4,000 in the volume) so that 300 poses end at
// a state of ~7,275, the paper's all-frames size; the loop closure makes it dense.
void BM_InformationFilterUpdate_PaperLoops7275(benchmark::State& state) {
  static const Problem problem = PaperProblem(4000);
  TimeUpdates(problem, static_cast<int>(problem.poses.size()), state);
}
BENCHMARK(BM_InformationFilterUpdate_PaperLoops7275)
    ->Iterations(kTimedUpdates)
    ->Unit(benchmark::kMillisecond);

// Lazy refactoring makes the cost of single updates uneven: the mean over 24 updates.
void BM_InformationFilterUpdate_PaperLoops7275_24(benchmark::State& state) {
  static const Problem problem = PaperProblem(4000);
  TimeUpdates(problem, static_cast<int>(problem.poses.size()), state);
}
BENCHMARK(BM_InformationFilterUpdate_PaperLoops7275_24)
    ->Iterations(24)
    ->Unit(benchmark::kMillisecond);

void BM_InformationFilterUpdate_PaperLoops7275_ExactRecovery(benchmark::State& state) {
  static const Problem problem = PaperProblem(4000);
  TimeUpdates(problem, static_cast<int>(problem.poses.size()), state, ExactRecovery());
}
BENCHMARK(BM_InformationFilterUpdate_PaperLoops7275_ExactRecovery)
    ->Iterations(kTimedUpdates)
    ->Unit(benchmark::kMillisecond);

void BM_InformationFilterUpdate_PaperLoops7275_SparseOnly(benchmark::State& state) {
  static const Problem problem = PaperProblem(4000);
  TimeUpdates(problem, static_cast<int>(problem.poses.size()), state, SparseOnly());
}
BENCHMARK(BM_InformationFilterUpdate_PaperLoops7275_SparseOnly)
    ->Iterations(kTimedUpdates)
    ->Unit(benchmark::kMillisecond);

// The corridor at ~7,275, ~19,000 and ~50,000 state dimensions (~19 a pose).
void BM_InformationFilterUpdate_Corridor(benchmark::State& state) {
  const int poses = static_cast<int>(state.range(0));
  const Problem problem = CorridorProblem(poses);
  TimeUpdates(problem, poses, state);
}
BENCHMARK(BM_InformationFilterUpdate_Corridor)
    ->Arg(382)
    ->Arg(1000)
    ->Arg(2620)
    ->Iterations(kTimedUpdates)
    ->Unit(benchmark::kMillisecond);

void BM_InformationFilterUpdate_Corridor_SparseOnly(benchmark::State& state) {
  const int poses = static_cast<int>(state.range(0));
  const Problem problem = CorridorProblem(poses);
  TimeUpdates(problem, poses, state, SparseOnly());
}
BENCHMARK(BM_InformationFilterUpdate_Corridor_SparseOnly)
    ->Arg(382)
    ->Iterations(kTimedUpdates)
    ->Unit(benchmark::kMillisecond);

// Growth with the number of poses on the paper's simulation (2,000 features): the update
// at pose N, for N = 50 ... 300.
void BM_InformationFilterUpdate_PaperGrowth(benchmark::State& state) {
  static const Problem problem = PaperProblem(2000);
  TimeUpdates(problem, static_cast<int>(state.range(0)), state);
}
BENCHMARK(BM_InformationFilterUpdate_PaperGrowth)
    ->DenseRange(50, 300, 50)
    ->Iterations(kTimedUpdates)
    ->Unit(benchmark::kMillisecond);

void BM_InformationFilterUpdate_PaperGrowth_ExactRecovery(benchmark::State& state) {
  static const Problem problem = PaperProblem(2000);
  TimeUpdates(problem, static_cast<int>(state.range(0)), state, ExactRecovery());
}
BENCHMARK(BM_InformationFilterUpdate_PaperGrowth_ExactRecovery)
    ->DenseRange(50, 300, 50)
    ->Iterations(kTimedUpdates)
    ->Unit(benchmark::kMillisecond);

// All 300 frames of the paper's simulation through the filter, one update each: the
// all-frames row of `ieslam simulate`.
void PaperAllFrames(benchmark::State& state, const InformationFilterOptions& options) {
  static const Problem problem = PaperProblem(2000);
  for (auto _ : state) {
    InformationFilter filter(options, problem.camera);
    filter.AddFirstPose(0, problem.poses[0], problem.observations[0]);
    double slowest = 0.0;
    for (size_t i = 1; i < problem.poses.size(); ++i) {
      filter.AddPose(static_cast<int>(i), problem.poses[i], problem.observations[i]);
      slowest = std::max(slowest, filter.last_timings().total_s);
    }
    // The run's report needs the exact factor once (covariances): lazy updates pay it here.
    benchmark::DoNotOptimize(filter.LogDetInformation());
    state.counters["max_update_ms"] = 1e3 * slowest;
    state.counters["state_dim"] = filter.state_dim();
    state.counters["factor_nnz"] = static_cast<double>(filter.FactorNonzeros());
  }
}

void BM_InformationFilter_PaperAllFrames(benchmark::State& state) {
  PaperAllFrames(state, PaperOptions());
}
BENCHMARK(BM_InformationFilter_PaperAllFrames)->Iterations(1)->Unit(benchmark::kSecond);

void BM_InformationFilter_PaperAllFrames_ExactRecovery(benchmark::State& state) {
  PaperAllFrames(state, ExactRecovery());
}
BENCHMARK(BM_InformationFilter_PaperAllFrames_ExactRecovery)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

void BM_InformationFilter_PaperAllFrames_SparseOnly(benchmark::State& state) {
  PaperAllFrames(state, SparseOnly());
}
BENCHMARK(BM_InformationFilter_PaperAllFrames_SparseOnly)->Iterations(1)->Unit(benchmark::kSecond);

// The joint covariance of 150 features seen by the last frames: what the selector recovers
// once per look-ahead buffer. After all 300 frames of the paper's simulation (dense: the
// paths of the features' columns cover the whole pose block), and at the end of a
// ~35,000-dimension corridor (a real-data map's size), each after a few in-place updates
// as in a run.
void JointFeatureCovariance150(const Problem& problem, benchmark::State& state) {
  const int end = static_cast<int>(problem.poses.size());
  InformationFilter filter(PaperOptions(), problem.camera);
  Load(problem, end - kWarmUpdates, &filter);
  for (int next = end - kWarmUpdates; next < end; ++next) AddNext(problem, next, &filter);
  std::vector<int64_t> ids;
  std::set<int64_t> seen;
  for (int i = static_cast<int>(problem.poses.size()) - 1; i >= 0 && ids.size() < 150; --i) {
    for (const FeatureObservation& obs : problem.observations[i]) {
      if (ids.size() < 150 && seen.insert(obs.feature_id).second) ids.push_back(obs.feature_id);
    }
  }
  for (auto _ : state) benchmark::DoNotOptimize(filter.JointFeatureCovariance(ids));
  state.counters["features"] = static_cast<double>(ids.size());
  state.counters["state_dim"] = filter.state_dim();
}

void BM_InformationFilter_JointFeatureCovariance150(benchmark::State& state) {
  static const Problem problem = PaperProblem(2000);
  JointFeatureCovariance150(problem, state);
}
BENCHMARK(BM_InformationFilter_JointFeatureCovariance150)
    ->Iterations(5)
    ->Unit(benchmark::kMillisecond);

void BM_InformationFilter_JointFeatureCovariance150_Corridor35k(benchmark::State& state) {
  static const Problem problem = CorridorProblem(1900);
  JointFeatureCovariance150(problem, state);
}
BENCHMARK(BM_InformationFilter_JointFeatureCovariance150_Corridor35k)
    ->Iterations(5)
    ->Unit(benchmark::kMillisecond);

// The selector's fast gain (Zhou et al. 2008, §V-A; InformationFilter::InformationGain): scoring
// one candidate given the joint covariance of the known features it observes, with 100 and 1000
// poses in the map. The scoring does not depend on the map's size; the covariance, recovered once
// per buffer, does, and is reported as the counter covariance_ms.
void BM_InformationGainPerCandidate_Corridor(benchmark::State& state) {
  const int poses = static_cast<int>(state.range(0));
  const Problem problem = CorridorProblem(poses + 1);
  InformationFilter filter(PaperOptions(), problem.camera);
  Load(problem, poses - kWarmUpdates, &filter);
  for (int next = poses - kWarmUpdates; next < poses; ++next) AddNext(problem, next, &filter);
  const std::vector<FeatureObservation>& candidate = problem.observations[poses];
  std::vector<int64_t> known;
  for (const FeatureObservation& obs : candidate) {
    if (filter.HasFeature(obs.feature_id)) known.push_back(obs.feature_id);
  }
  const auto start = std::chrono::steady_clock::now();
  const FeatureCovariance covariance = filter.JointFeatureCovariance(known);
  const double covariance_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const int new_features = filter.CountFirstSightings(candidate);
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        filter.InformationGain(problem.poses[poses], candidate, new_features, covariance));
  }
  state.counters["known_features"] = static_cast<double>(known.size());
  state.counters["state_dim"] = filter.state_dim();
  state.counters["covariance_ms"] = covariance_ms;
}
BENCHMARK(BM_InformationGainPerCandidate_Corridor)
    ->Arg(100)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace ieslam
