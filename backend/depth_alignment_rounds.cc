// The depth-aligned bundle adjustment: rounds of pairwise alignment (depth_alignment.cc)
// and bundle adjustment with the pairs' constraints (SolveWithDepthAlignment).
#include <algorithm>
#include <chrono>
#include <functional>
#include <optional>

#include "backend/depth_alignment.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

// The largest PoseChange of any pose from `before` to `after` (frames of `after`).
double LargestPoseChange(const std::map<int, Eigen::Isometry3d>& before,
                         const std::map<int, Eigen::Isometry3d>& after) {
  double change = 0.0;
  for (const auto& [frame, T] : after) change = std::max(change, PoseChange(before.at(frame), T));
  return change;
}

// The sample step of the round after one at `step` whose solve is `solved`, with the
// constraints' variance factor so far `variance_factor`. Where the constraints prove about
// as precise as they state (a factor below kIndependentFactor, measured on at least
// kMinConstraints of them: the points' errors are independent at least at this spacing),
// denser points may add information, and the step halves, down to dense_sample_step; each
// round measures its own factor, so any correlation at the finer spacing is weighed out
// there. Where the factor is larger, the errors are correlated over more than the sample
// spacing, and denser points would only add time and stated information that the factor
// takes back.
int NextSampleStep(int step, double variance_factor, int constraints,
                   const BundleAdjustmentResult& solved, const BundleAdjustmentOptions& ba_options,
                   const DepthAlignmentOptions& options) {
  constexpr double kIndependentFactor = 2.0;
  constexpr int kMinConstraints = 10;  // the median of fewer says little
  const int measured = constraints - solved.rejected_relative_poses;
  const bool denser = ba_options.weigh_relative_poses && measured >= kMinConstraints &&
                      variance_factor < kIndependentFactor && step > options.dense_sample_step;
  return denser ? std::max(options.dense_sample_step, step / 2) : step;
}

// The result that stands when a later round does not: computed before it was known to be
// the last, it has no covariances, and says why.
void NoteMissingCovariances(const BundleAdjustmentOptions& ba_options, const std::string& why,
                            BundleAdjustmentResult* result) {
  if (ba_options.compute_covariances && result->pose_covariances.empty() &&
      result->covariance_error.empty()) {
    result->covariance_error = "not computed: " + why;
  }
}

// A round's constraints at the poses of `problem`, their information divided by the variance
// factor so far. The pairs that `last` (the last round's solve of `problem`) kept start from
// their own alignment there: the poses that solve settled on are a compromise with the
// features (centimetres from a pair's own optimum on real depth), and a start at that optimum
// converges in a few fine steps.
std::vector<RelativePoseConstraint> RoundConstraints(const std::map<int, RangeCloud>& clouds,
                                                     const BundleAdjustmentProblem& problem,
                                                     const BundleAdjustmentResult& last,
                                                     const DepthAlignmentOptions& options,
                                                     double variance_factor,
                                                     DepthAlignmentStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<RelativePoseConstraint> kept;
  for (size_t k = 0; k < problem.relative_poses.size(); ++k) {
    if (k < last.relative_pose_kept.size() && last.relative_pose_kept[k]) {
      kept.push_back(problem.relative_poses[k]);
    }
  }
  std::vector<RelativePoseConstraint> constraints =
      AlignCloudPairs(clouds, problem.T_w_c, options, stats, &kept);
  for (RelativePoseConstraint& c : constraints) c.sqrt_information /= std::sqrt(variance_factor);
  stats->seconds_alignment += SecondsSince(start);
  return constraints;
}

// A round solved with early_rejection_rounds, kept while its result stands so that it can be
// solved again with every rejection round should a later round fail: its constraints, the
// poses and features it started from, and the variance factor and step it was solved with.
struct EarlyRound {
  std::vector<RelativePoseConstraint> relative_poses;
  std::map<int, Eigen::Isometry3d> T_w_c;
  std::map<int64_t, Eigen::Vector3d> p_w;
  double variance_factor = 1.0;
  int sample_step = 0;
};

// The bundle adjustment of one round: with `early_rejection_rounds` rounds of rejections and no
// covariances when `early` (*solved_early then true), unless that result `ends` the
// alternation, which is then solved again with `full`, as the last round is.
BundleAdjustmentResult SolveRound(const BundleAdjustmentProblem& problem,
                                  const PinholeCamera& camera, const BundleAdjustmentOptions& full,
                                  int early_rejection_rounds, bool early,
                                  const std::function<bool(const BundleAdjustmentResult&)>& ends,
                                  bool* solved_early) {
  *solved_early = false;
  if (early) {
    BundleAdjustmentOptions early_ba = full;
    early_ba.max_rejection_rounds = early_rejection_rounds;
    early_ba.compute_covariances = false;
    BundleAdjustmentResult solved = SolveBundleAdjustment(problem, camera, early_ba);
    if (!solved.usable || solved.interrupted || !ends(solved)) {
      *solved_early = true;
      return solved;
    }
  }
  return SolveBundleAdjustment(problem, camera, full);
}

// The alternation of SolveWithDepthAlignment, round by round, and what it carries from one
// round to the next.
class Alternation {
 public:
  Alternation(BundleAdjustmentProblem problem, const PinholeCamera& camera,
              const std::map<int, RangeCloud>& clouds, const BundleAdjustmentOptions& ba_options,
              const DepthAlignmentOptions& options, DepthAlignmentStats* stats)
      : problem_(std::move(problem)),
        camera_(camera),
        clouds_(clouds),
        ba_options_(ba_options),
        options_(options),
        s_(stats),
        round_options_(options) {}

  // Aligns and solves round `round`; false when the alternation ends with it (the last
  // round, convergence, a failure or an interruption).
  bool Round(int round);
  BundleAdjustmentResult TakeResult() { return std::move(result_); }

 private:
  void Stand(BundleAdjustmentResult&& solved) {
    s_->variance_factor = variance_factor_ * solved.relative_pose_variance_factor;
    s_->sample_step = round_options_.sample_step;
    result_ = std::move(solved);
  }
  // A round whose solve failed or was interrupted is dropped: the last usable one stands (the
  // caller sees usable == false only when the first round failed), solved again with every
  // rejection round if it was solved early and the later one failed, else without covariances.
  void Drop(int round, BundleAdjustmentResult&& solved);

  BundleAdjustmentProblem problem_;
  const PinholeCamera& camera_;
  const std::map<int, RangeCloud>& clouds_;
  const BundleAdjustmentOptions& ba_options_;
  const DepthAlignmentOptions& options_;
  DepthAlignmentStats* s_;
  BundleAdjustmentResult result_;
  // The constraints' variance factor so far (BundleAdjustmentOptions::weigh_relative_poses):
  // each round's constraints start at the weight the last round found, so that its first
  // solve does not follow overstated surfaces. It only grows (each round's factor is >= 1):
  // measured at a solution the constraints dominate, the median of their residuals
  // understates their noise, so a later round's larger factor is the better one.
  double variance_factor_ = 1.0;
  // The first round samples the clouds at options.sample_step, later ones as NextSampleStep
  // finds; a round that samples more densely than the last is not skipped for convergence.
  DepthAlignmentOptions round_options_;
  std::optional<EarlyRound> early_round_;  // the round that stands, if solved early
};

bool Alternation::Round(int round) {
  if (round > 0 && ba_options_.stop && ba_options_.stop()) {
    NoteMissingCovariances(ba_options_, "interrupted before the next depth-aligned round",
                           &result_);
    result_.interrupted = true;
    return false;
  }
  problem_.relative_poses =
      RoundConstraints(clouds_, problem_, result_, round_options_, variance_factor_, s_);
  // The next round's step, and whether the alternation ends with `solved` (the last round,
  // or no pose moved by convergence_m and the step stays): only that solve, whose result
  // stands, computes covariances.
  const auto next_step = [&](const BundleAdjustmentResult& solved) {
    return NextSampleStep(round_options_.sample_step,
                          variance_factor_ * solved.relative_pose_variance_factor, s_->constraints,
                          solved, ba_options_, options_);
  };
  const auto ends_with = [&](const BundleAdjustmentResult& solved) {
    return round + 1 == options_.rounds ||
           (next_step(solved) == round_options_.sample_step &&
            LargestPoseChange(problem_.T_w_c, solved.T_w_c) < options_.convergence_m);
  };
  BundleAdjustmentOptions round_ba = ba_options_;
  round_ba.covariances_wanted = [&](const BundleAdjustmentResult& solved) {
    return ends_with(solved) &&
           (!ba_options_.covariances_wanted || ba_options_.covariances_wanted(solved));
  };
  const bool early = round + 1 < options_.rounds && options_.early_rejection_rounds >= 0 &&
                     options_.early_rejection_rounds < ba_options_.max_rejection_rounds;
  const auto ba_start = std::chrono::steady_clock::now();
  bool solved_early = false;
  BundleAdjustmentResult solved =
      SolveRound(problem_, camera_, round_ba, options_.early_rejection_rounds, early, ends_with,
                 &solved_early);
  s_->seconds_ba += SecondsSince(ba_start);
  ++s_->rounds;
  if (!solved.usable || solved.interrupted) {
    Drop(round, std::move(solved));
    return false;
  }
  const bool last = ends_with(solved);
  const int step = next_step(solved);
  early_round_.reset();
  if (solved_early) {
    // The starting poses and features move in below, where the next round's replace them.
    early_round_ =
        EarlyRound{problem_.relative_poses, {}, {}, variance_factor_, round_options_.sample_step};
  }
  Stand(std::move(solved));
  variance_factor_ = s_->variance_factor;
  if (last) return false;  // never after an early solve, which does not end the alternation
  if (early_round_) {
    early_round_->T_w_c = std::move(problem_.T_w_c);
    early_round_->p_w = std::move(problem_.p_w);
  }
  problem_.T_w_c = result_.T_w_c;
  problem_.p_w = result_.p_w;
  round_options_.sample_step = step;
  return true;
}

void Alternation::Drop(int round, BundleAdjustmentResult&& solved) {
  const bool interrupted = solved.interrupted;
  const std::string why = interrupted ? "was interrupted" : "failed (" + solved.termination + ")";
  if (round == 0) Stand(std::move(solved));
  if (round > 0 && early_round_ && !interrupted) {
    problem_.relative_poses = std::move(early_round_->relative_poses);
    problem_.T_w_c = std::move(early_round_->T_w_c);
    problem_.p_w = std::move(early_round_->p_w);
    variance_factor_ = early_round_->variance_factor;
    round_options_.sample_step = early_round_->sample_step;
    early_round_.reset();
    const auto start = std::chrono::steady_clock::now();
    BundleAdjustmentResult again = SolveBundleAdjustment(problem_, camera_, ba_options_);
    s_->seconds_ba += SecondsSince(start);
    if (again.usable && !again.interrupted) Stand(std::move(again));
  }
  if (round > 0) {
    NoteMissingCovariances(ba_options_, "the depth-aligned round after it " + why, &result_);
  }
  if (interrupted) result_.interrupted = true;
}

}  // namespace

BundleAdjustmentResult SolveWithDepthAlignment(BundleAdjustmentProblem problem,
                                               const PinholeCamera& camera,
                                               const std::map<int, RangeCloud>& clouds,
                                               const BundleAdjustmentOptions& ba_options,
                                               const DepthAlignmentOptions& options,
                                               DepthAlignmentStats* stats) {
  DepthAlignmentStats local;
  DepthAlignmentStats* s = stats != nullptr ? stats : &local;
  *s = DepthAlignmentStats();
  if (options.rounds == 0) return SolveBundleAdjustment(problem, camera, ba_options);
  Alternation alternation(std::move(problem), camera, clouds, ba_options, options, s);
  int round = 0;
  while (round < options.rounds && alternation.Round(round)) ++round;
  return alternation.TakeResult();
}

}  // namespace ieslam
