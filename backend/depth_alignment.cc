#include "backend/depth_alignment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include <Eigen/Eigenvalues>

#include "core/error.h"
#include "core/parallel_for.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

// The Gauss-Newton system of the point-to-plane residuals r = n_t . (Y p_s - q_t) at Y, in
// the chart Y <- [Exp(omega), v] Y, whose Jacobian is ((Y p_s) x n_t, n_t), and the cost
// the alignment minimises: sum over the sampled source points of the Huber loss of r /
// sigma where a point has a partner, and of the loss at the gate where it has none. With
// that constant for the unmatched, the cost is one function of Y however the gates switch
// points in and out, and a step that lowers it can be told from one that does not.
struct NormalEquations {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  double cost = 0.0;
  int count = 0;
  std::vector<double> abs_whitened;  // |r| / sigma per correspondence
};

double Huber(double abs_whitened, double k) {
  return abs_whitened <= k ? 0.5 * abs_whitened * abs_whitened : k * (abs_whitened - 0.5 * k);
}

// Source point `index` moved by Y to *a has a partner on the target's surface: the
// interpolated point *q with normal *n and range sigma *sigma_t within gate_m of it, the
// normals within the options' angle.
bool Partner(const RangeCloud& source, const RangeCloud& target, int index,
             const Eigen::Isometry3d& Y, double gate_m, double min_normal_cos,
             const DepthAlignmentOptions& options, Eigen::Vector3d* a, Eigen::Vector3d* q,
             Eigen::Vector3d* n, double* sigma_t) {
  *a = Y * source.p_r[index].cast<double>();
  return target.Interpolate(*a, options.max_depth_ratio, q, n, sigma_t) &&
         !((*a - *q).squaredNorm() > gate_m * gate_m) &&
         !((Y.linear() * source.n_r[index].cast<double>()).dot(*n) < min_normal_cos);
}

double MinNormalCos(const DepthAlignmentOptions& options) {
  return std::cos(options.max_normal_angle_deg * M_PI / 180.0);
}

// How many of `samples` have a partner (Partner) at Y: the overlap test, without the
// normal equations.
int CountPartners(const RangeCloud& source, const RangeCloud& target,
                  const std::vector<int>& samples, const Eigen::Isometry3d& Y, double gate_m,
                  const DepthAlignmentOptions& options) {
  const double min_normal_cos = MinNormalCos(options);
  int count = 0;
  Eigen::Vector3d a, q, n;
  double sigma_t = 0.0;
  for (const int index : samples) {
    if (Partner(source, target, index, Y, gate_m, min_normal_cos, options, &a, &q, &n, &sigma_t)) {
      ++count;
    }
  }
  return count;
}

NormalEquations Associate(const RangeCloud& source, const RangeCloud& target,
                          const std::vector<int>& samples, const Eigen::Isometry3d& Y,
                          double gate_m, const DepthAlignmentOptions& options) {
  const double min_normal_cos = MinNormalCos(options);
  NormalEquations eq;
  eq.abs_whitened.reserve(samples.size());
  for (const int index : samples) {
    const double sigma_s = source.sigma_m[index];
    const double unmatched = Huber(gate_m / (std::sqrt(2.0) * sigma_s), options.huber_sigmas);
    Eigen::Vector3d a, q, n;
    double sigma_t = 0.0;
    if (!Partner(source, target, index, Y, gate_m, min_normal_cos, options, &a, &q, &n, &sigma_t)) {
      eq.cost += unmatched;
      continue;
    }
    const double r = n.dot(a - q);
    const double variance = sigma_s * sigma_s + sigma_t * sigma_t;
    const double whitened = std::abs(r) / std::sqrt(variance);
    eq.cost += std::min(unmatched, Huber(whitened, options.huber_sigmas));
    double w = 1.0 / variance;
    if (whitened > options.huber_sigmas) w *= options.huber_sigmas / whitened;
    Vector6d J;
    J << a.cross(n), n;
    eq.H.noalias() += w * J * J.transpose();
    eq.g.noalias() += w * r * J;
    ++eq.count;
    eq.abs_whitened.push_back(whitened);
  }
  return eq;
}

// The minimum-norm solution of H x = -g: directions H does not determine (a plane slides
// along itself) get no step instead of an arbitrary one.
Vector6d GaussNewtonStep(const NormalEquations& eq) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(eq.H);
  const Vector6d& lambda = eigen.eigenvalues();
  Vector6d step = Vector6d::Zero();
  const double cutoff = 1e-10 * lambda.maxCoeff();
  for (int k = 0; k < 6; ++k) {
    if (lambda[k] > cutoff) {
      const Vector6d u = eigen.eigenvectors().col(k);
      step -= u * (u.dot(eq.g) / lambda[k]);
    }
  }
  return step;
}

Eigen::Isometry3d Increment(const Vector6d& omega_v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double angle = omega_v.head<3>().norm();
  if (angle > 0.0) {
    T.linear() = Eigen::AngleAxisd(angle, omega_v.head<3>() / angle).toRotationMatrix();
  }
  T.translation() = omega_v.tail<3>();
  return T;
}

std::vector<int> Samples(const RangeCloud& cloud, int step) {
  std::vector<int> samples;
  for (int y = 0; y < cloud.grid.height; y += step) {
    for (int x = 0; x < cloud.grid.width; x += step) {
      const int index = y * cloud.grid.width + x;
      if (cloud.Valid(index)) samples.push_back(index);
    }
  }
  return samples;
}

Matrix6d SqrtOf(const Matrix6d& H) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (H + H.transpose()));
  const Vector6d root = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return root.asDiagonal() * eigen.eigenvectors().transpose();
}

Eigen::Isometry3d SensorPose(const Eigen::Isometry3d& T_w_c, const RangeCloud& cloud) {
  return T_w_c * cloud.T_colour_range;
}

// Which of `all_pairs` (frame indices a < b) to align: each frame keeps at most
// max_partners of its overlapping partners, spread over the sequence. Its partners in frame
// order are cut into max_partners runs of equal length and the most overlapping one of each
// run is kept; a pair is aligned when either of its frames keeps it. That bounds the work and
// the bundle adjustment's terms to max_partners per frame however long the sequence.
// Keeping the most overlapping ones instead would keep the nearest frames only; the far
// ones, which see the same surfaces after a loop, are the ones that remove drift.
// A run that holds pairs with an `own_start` (OwnStarts) keeps the most overlapping of those
// instead: which of a run's pairs overlaps most changes with millimetre moves of the poses,
// and a pair chosen anew is aligned from the poses through the coarse phase, where one
// started from its own earlier alignment converges in a step or two.
std::vector<char> SpreadPartners(const std::vector<std::pair<size_t, size_t>>& all_pairs,
                                 const std::vector<double>& overlap,
                                 const std::vector<std::optional<Eigen::Isometry3d>>& own_start,
                                 size_t num_frames, const DepthAlignmentOptions& options) {
  std::vector<std::vector<size_t>> partners(num_frames);  // pair indices, in frame order
  for (size_t k = 0; k < all_pairs.size(); ++k) {
    if (overlap[k] < options.min_overlap) continue;
    partners[all_pairs[k].first].push_back(k);
    partners[all_pairs[k].second].push_back(k);
  }
  std::vector<char> keep(all_pairs.size(), 0);
  for (size_t a = 0; a < num_frames; ++a) {
    std::vector<size_t>& list = partners[a];
    const auto other = [&](size_t k) {
      return all_pairs[k].first == a ? all_pairs[k].second : all_pairs[k].first;
    };
    std::sort(list.begin(), list.end(), [&](size_t x, size_t y) { return other(x) < other(y); });
    const size_t runs = std::min(list.size(), static_cast<size_t>(options.max_partners));
    for (size_t run = 0; run < runs; ++run) {
      const size_t begin = run * list.size() / runs, end = (run + 1) * list.size() / runs;
      size_t best = list[begin];
      for (size_t m = begin + 1; m < end; ++m) {
        const size_t k = list[m];
        const bool own = own_start[k].has_value(), best_own = own_start[best].has_value();
        if (own != best_own ? own : overlap[k] > overlap[best]) best = k;
      }
      keep[best] = 1;
    }
  }
  return keep;
}

// One Gauss-Newton step with backtracking at *Y: the full step, else halves of it, the first
// that lowers the cost moves *Y and *eq to it (true); none does at a minimum of the cost as
// the gates cut it (false). *step is the last step tried.
bool BacktrackingStep(const RangeCloud& source, const RangeCloud& target,
                      const std::vector<int>& samples, double gate_m,
                      const DepthAlignmentOptions& options, Eigen::Isometry3d* Y,
                      NormalEquations* eq, Vector6d* step) {
  *step = GaussNewtonStep(*eq);
  for (int halving = 0; halving < 4; ++halving) {
    const Eigen::Isometry3d Y_next = Increment(*step) * *Y;
    NormalEquations next = Associate(source, target, samples, Y_next, gate_m, options);
    if (next.cost < eq->cost) {
      *Y = Y_next;
      *eq = std::move(next);
      return true;
    }
    *step *= 0.5;
  }
  return false;
}

// A converged alignment's information, overlap and spread from its final normal equations
// over `samples` source points, and whether it counts (DepthAlignmentOptions).
void Judge(const NormalEquations& eq, size_t samples, const DepthAlignmentOptions& options,
           PairAlignment* result) {
  result->information = 0.5 * (eq.H + eq.H.transpose());
  result->correspondences = eq.count;
  result->overlap = samples == 0 ? 0.0 : static_cast<double>(eq.count) / samples;
  result->robust_sigma = RobustSigma(eq.abs_whitened);
  if (eq.count < options.min_correspondences || result->overlap < options.min_overlap) {
    result->why_not = "overlap " + std::to_string(result->overlap) + " too small";
  } else if (result->robust_sigma > options.max_robust_sigma) {
    result->why_not = "surfaces apart (robust sigma " + std::to_string(result->robust_sigma) + ")";
  } else {
    result->usable = true;
  }
}

}  // namespace

double PoseChange(const Eigen::Isometry3d& before, const Eigen::Isometry3d& after) {
  const Eigen::Isometry3d D = before.inverse() * after;
  return std::max(D.translation().norm(), Eigen::AngleAxisd(D.linear()).angle());
}

const OptionTable<DepthAlignmentOptions>& DepthAlignmentOptions::Table() {
  static const OptionTable<DepthAlignmentOptions>* table = [] {
    using O = DepthAlignmentOptions;
    auto* t = new OptionTable<O>;
    t->Int("rounds", &O::rounds,
           "alternations of pairwise alignment and bundle adjustment (0: off)")
        .Min(0);
    t->Int("sample_step", &O::sample_step, "every n-th cloud point is matched (first round)")
        .Range(1, 64);
    t->Int("dense_sample_step", &O::dense_sample_step,
           "later rounds' step where the points prove independent")
        .Range(1, 64);
    t->Double("initial_gate_m", &O::initial_gate_m,
              "point-to-point association gate, until converged")
        .Above(0.0);
    t->Double("final_gate_m", &O::final_gate_m, "... then this one").Above(0.0);
    t->Double("max_normal_angle_deg", &O::max_normal_angle_deg, "matched normals within this angle")
        .Above(0.0)
        .Max(90.0);
    t->Double("huber_sigmas", &O::huber_sigmas, "Huber weights on the point-to-plane residual")
        .Above(0.0);
    t->Double("min_overlap", &O::min_overlap, "share of matched points for a pair to count")
        .Above(0.0)
        .Max(1.0);
    t->Double("max_robust_sigma", &O::max_robust_sigma,
              "whitened residual spread above which a pair is rejected")
        .Above(0.0);
    t->Int("max_partners", &O::max_partners, "each frame picks at most this many others").Min(1);
    t->Int("max_iterations", &O::max_iterations, "Gauss-Newton iterations of an alignment").Min(1);
    t->Double("max_depth_ratio", &O::max_depth_ratio,
              "a target surface's grid points within this share of their depth")
        .Above(0.0);
    t->Int("min_correspondences", &O::min_correspondences, "matched points a pair needs").Min(6);
    t->Double("convergence_m", &O::convergence_m, "rounds stop once no pose moves more").Min(0.0);
    t->Int("early_rejection_rounds", &O::early_rejection_rounds,
           "rejection rounds of a round that does not end the alternation (-1: all)")
        .Min(-1);
    t->Int("num_threads", &O::num_threads, "pairs aligned in parallel: from the run's threads")
        .Min(1)
        .Derived();
    t->Require([](const O& o) {
      return o.final_gate_m <= o.initial_gate_m ? std::string()
                                                : "final_gate_m must be <= initial_gate_m";
    });
    t->Require([](const O& o) {
      return o.dense_sample_step <= o.sample_step ? std::string()
                                                  : "dense_sample_step must be <= sample_step";
    });
    t->Require([](const O& o) {
      return o.early_rejection_rounds != 0
                 ? std::string()
                 : "early_rejection_rounds must be -1 or at least 1: a solve without a round of "
                   "rejections never weighs the pairs, and the next round's sampling follows "
                   "their weight";
    });
    return t;
  }();
  return *table;
}

namespace {

// Per pair of frame indices in `all_pairs`, the pair's own start from `starts` (frame ids
// by `frames`, sensor poses T_w_s), if it has one. A start stands only within
// `gate_m` of where the poses put the pair (rotations at 1 m): one further off may have
// settled in another basin, and the poses, which the other pairs and the features agree
// on, are the better guide there.
std::vector<std::optional<Eigen::Isometry3d>> OwnStarts(
    const std::vector<std::pair<size_t, size_t>>& all_pairs, const std::vector<int>& frames,
    const std::vector<Eigen::Isometry3d>& T_w_s, const std::vector<RelativePoseConstraint>* starts,
    double gate_m) {
  std::map<std::pair<int, int>, Eigen::Isometry3d> own_start;
  if (starts != nullptr) {
    for (const RelativePoseConstraint& c : *starts) own_start[{c.frame_i, c.frame_j}] = c.T_sj_si;
  }
  std::vector<std::optional<Eigen::Isometry3d>> start_of(all_pairs.size());
  for (size_t k = 0; k < all_pairs.size() && !own_start.empty(); ++k) {
    const auto [a, b] = all_pairs[k];
    const auto own = own_start.find({frames[a], frames[b]});
    if (own != own_start.end() && PoseChange(T_w_s[b].inverse() * T_w_s[a], own->second) < gate_m) {
      start_of[k] = own->second;
    }
  }
  return start_of;
}

// AlignRangeClouds; `converged_start` says T_t_s_initial is the pair's own earlier
// alignment, already in the final phase's basin, and the coarse phase is skipped.
PairAlignment Align(const RangeCloud& source, const RangeCloud& target,
                    const Eigen::Isometry3d& T_t_s_initial, const DepthAlignmentOptions& options,
                    bool converged_start) {
  PairAlignment result;
  const std::vector<int> samples = Samples(source, options.sample_step);
  result.samples = static_cast<int>(samples.size());
  // Coarse to fine: the first phase only brings the pose into the final phase's basin, so it
  // matches a quarter of the points (the grid at twice the step) under the initial gate; the
  // final phase matches them all under the final gate, and its minimum is the result.
  const std::vector<int> coarse = Samples(source, 2 * options.sample_step);
  struct Phase {
    const std::vector<int>* samples;
    double gate_m;
    int min_correspondences;  // the same share of the phase's samples, and 6 for a pose
  };
  const double coarse_share =
      samples.empty() ? 0.0 : static_cast<double>(coarse.size()) / samples.size();
  const Phase phases[2] = {
      {&coarse, options.initial_gate_m,
       std::max(6, static_cast<int>(std::ceil(options.min_correspondences * coarse_share)))},
      {&samples, options.final_gate_m, options.min_correspondences}};
  // A cloud too sparse for the coarse phase starts at the fine one.
  int phase =
      converged_start || static_cast<int>(coarse.size()) < phases[0].min_correspondences ? 1 : 0;
  Eigen::Isometry3d Y = T_t_s_initial;
  bool converged = false;
  // Converged once a step is below a tenth of a millimetre (and of a milliradian, a tenth of
  // a millimetre at 1 m), an order of magnitude under any point's range noise: the gates
  // switch single points in and out near the optimum and keep steps of ~1e-5 going forever.
  constexpr double kConverged = 1e-4;
  NormalEquations eq =
      Associate(source, target, *phases[phase].samples, Y, phases[phase].gate_m, options);
  for (int it = 0; it < options.max_iterations && !converged; ++it) {
    const Phase& current = phases[phase];
    if (eq.count < current.min_correspondences) {
      result.why_not = "too few correspondences (" + std::to_string(eq.count) + " of " +
                       std::to_string(current.samples->size()) + ")";
      return result;
    }
    Vector6d step;
    const bool moved =
        BacktrackingStep(source, target, *current.samples, current.gate_m, options, &Y, &eq, &step);
    ++result.iterations;
    if (!moved || (step.head<3>().norm() < kConverged && step.tail<3>().norm() < kConverged)) {
      if (phase == 1) {
        converged = true;
      } else {
        phase = 1;
        eq = Associate(source, target, samples, Y, phases[1].gate_m, options);
      }
    }
  }
  if (!converged) {
    result.why_not = "no convergence in " + std::to_string(options.max_iterations) + " iterations";
    return result;
  }
  result.T_t_s = Y;
  Judge(eq, samples.size(), options, &result);
  return result;
}

}  // namespace

PairAlignment AlignRangeClouds(const RangeCloud& source, const RangeCloud& target,
                               const Eigen::Isometry3d& T_t_s_initial,
                               const DepthAlignmentOptions& options) {
  return Align(source, target, T_t_s_initial, options, false);
}

std::vector<RelativePoseConstraint> AlignCloudPairs(
    const std::map<int, RangeCloud>& clouds, const std::map<int, Eigen::Isometry3d>& T_w_c,
    const DepthAlignmentOptions& options, DepthAlignmentStats* stats,
    const std::vector<RelativePoseConstraint>* starts) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  std::vector<int> frames;
  for (const auto& [frame, cloud] : clouds) {
    if (T_w_c.count(frame) > 0) frames.push_back(frame);
  }
  // Pairs whose clouds overlap at the given poses: a sparse subset of one cloud's points
  // (one per 4 sampled) lands on the other's surfaces, within the initial gate, often enough.
  std::vector<Eigen::Isometry3d> T_w_s;
  std::vector<std::vector<int>> coarse_samples;
  for (const int frame : frames) {
    T_w_s.push_back(SensorPose(T_w_c.at(frame), clouds.at(frame)));
    coarse_samples.push_back(Samples(clouds.at(frame), 2 * options.sample_step));
  }
  std::vector<std::pair<size_t, size_t>> all_pairs;
  for (size_t a = 0; a < frames.size(); ++a) {
    for (size_t b = a + 1; b < frames.size(); ++b) all_pairs.emplace_back(a, b);
  }
  std::vector<double> overlap(all_pairs.size(), 0.0);
  const auto screen_start = std::chrono::steady_clock::now();
  ParallelFor(all_pairs.size(), options.num_threads, [&](size_t k) {
    const auto [a, b] = all_pairs[k];
    if (coarse_samples[a].empty()) return;
    const int count = CountPartners(clouds.at(frames[a]), clouds.at(frames[b]), coarse_samples[a],
                                    T_w_s[b].inverse() * T_w_s[a], options.initial_gate_m, options);
    overlap[k] = static_cast<double>(count) / coarse_samples[a].size();
  });
  if (stats != nullptr) stats->seconds_screen += SecondsSince(screen_start);
  const std::vector<std::optional<Eigen::Isometry3d>> own_start =
      OwnStarts(all_pairs, frames, T_w_s, starts, options.initial_gate_m);
  const std::vector<char> keep =
      SpreadPartners(all_pairs, overlap, own_start, frames.size(), options);
  std::vector<std::pair<int, int>> pairs;
  std::vector<size_t> kept;  // indices into all_pairs, as `pairs`
  for (size_t k = 0; k < all_pairs.size(); ++k) {
    if (!keep[k]) continue;
    pairs.emplace_back(frames[all_pairs[k].first], frames[all_pairs[k].second]);
    kept.push_back(k);
  }
  std::vector<PairAlignment> aligned(pairs.size());
  ParallelFor(pairs.size(), options.num_threads, [&](size_t m) {
    const auto [a, b] = all_pairs[kept[m]];
    const std::optional<Eigen::Isometry3d>& own = own_start[kept[m]];
    aligned[m] = Align(clouds.at(frames[a]), clouds.at(frames[b]),
                       own.value_or(T_w_s[b].inverse() * T_w_s[a]), options, own.has_value());
  });

  std::vector<RelativePoseConstraint> constraints;
  double overlap_sum = 0.0;
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (!aligned[k].usable) continue;
    RelativePoseConstraint c;
    c.frame_i = pairs[k].first;
    c.frame_j = pairs[k].second;
    c.T_sj_si = aligned[k].T_t_s;
    c.T_c_s = clouds.at(c.frame_i).T_colour_range;
    c.sqrt_information = SqrtOf(aligned[k].information);
    constraints.push_back(c);
    overlap_sum += aligned[k].overlap;
  }
  if (stats != nullptr) {
    stats->pairs_tried = static_cast<int>(pairs.size());
    stats->constraints = static_cast<int>(constraints.size());
    stats->iterations = 0;
    for (const PairAlignment& a : aligned) stats->iterations += a.iterations;
    stats->mean_overlap = constraints.empty() ? 0.0 : overlap_sum / constraints.size();
  }
  return constraints;
}

}  // namespace ieslam
