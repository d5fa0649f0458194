#include "backend/observation_gate.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/chi_square.h"

namespace ieslam {
namespace {

// Robust iterations before the gate (Cauchy weights at the gate's scale), and fits of the
// kept set between its tests: each converges in a few Gauss-Newton steps from a
// registration's pose.
constexpr int kRobustIterations = 6;
constexpr int kGateRounds = 8;
constexpr int kMaxJointDrops = 12;
constexpr int kNoiseRounds = 4;
constexpr int kFitIterations = 6;
constexpr double kConverged = 1e-8;  // metres and radians: far below any sigma
// Below it the observations do not determine the pose (see PoseStep).
constexpr double kMinNormalisedEigenvalue = 1e-9;

// One observation of a map feature (known, or pending with its covariance in `known`) at the
// current pose.
struct Term {
  int input = -1;      // index into the observations
  int block = -1;      // the feature's block in `known`
  bool valid = false;  // in front of the camera: linearisable
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
  Matrix36d J_x = Matrix36d::Zero();
  Eigen::Matrix3d J_f = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();  // Q + J_f P_f J_f^T
  double d2 = 0.0;
};

void Linearize(const InformationFilter& filter, const Vector6d& T_w_c,
               const std::vector<FeatureObservation>& observations, const FeatureCovariance& known,
               std::vector<Term>* terms) {
  for (Term& t : *terms) {
    const FeatureObservation& obs = observations[t.input];
    const Eigen::Vector3d p_w = filter.MapFeature(obs.feature_id);
    t.valid = WorldToCamera(T_w_c, p_w).z() > filter.options().min_depth_m;
    if (!t.valid) continue;
    t.r = obs.z - PredictObservation(T_w_c, p_w, filter.camera(), &t.J_x, &t.J_f);
    const Eigen::Matrix3d P_f = known.covariance.block<3, 3>(3 * t.block, 3 * t.block);
    t.S = obs.Q + t.J_f * P_f * t.J_f.transpose();
    t.d2 = t.r.dot(t.S.ldlt().solve(t.r));
  }
}

// One Gauss-Newton step of the pose on the terms with `weight` > 0; false when they do not
// determine it. P_x is the step's covariance (H^-1, weights taken as information scales).
bool PoseStep(const std::vector<Term>& terms, const std::vector<double>& weight, Vector6d* step,
              Matrix6d* P_x) {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  for (size_t k = 0; k < terms.size(); ++k) {
    if (!terms[k].valid || weight[k] <= 0.0) continue;
    const Eigen::Matrix<double, 6, 3> JtSi =
        terms[k].J_x.transpose() * terms[k].S.inverse() * weight[k];
    H += JtSi * terms[k].J_x;
    g += JtSi * terms[k].r;
  }
  const Eigen::Matrix<double, 6, 1> diagonal = H.diagonal();
  if (!(diagonal.minCoeff() > 0.0) || !std::isfinite(diagonal.maxCoeff())) return false;
  // Rank: the smallest eigenvalue of H scaled to a unit diagonal, free of the units of
  // rotation and translation. Two features (rotation about the line through them) or
  // collinear ones leave a direction undetermined, and a Cholesky of H can still succeed.
  const Vector6d inv_sqrt = diagonal.cwiseSqrt().cwiseInverse();
  const Matrix6d normalised = inv_sqrt.asDiagonal() * H * inv_sqrt.asDiagonal();
  if (!(Eigen::SelfAdjointEigenSolver<Matrix6d>(normalised, Eigen::EigenvaluesOnly)
            .eigenvalues()
            .minCoeff() > kMinNormalisedEigenvalue)) {
    return false;
  }
  const Eigen::LLT<Matrix6d> llt(H);
  if (llt.info() != Eigen::Success) return false;
  *step = llt.solve(g);
  *P_x = llt.solve(Matrix6d::Identity());
  return step->allFinite();
}

// The residual test of each term against the fit with covariance P_x of the kept ones.
void Studentize(const std::vector<bool>& kept, const Matrix6d& P_x, std::vector<Term>* terms) {
  for (size_t k = 0; k < terms->size(); ++k) {
    Term& t = (*terms)[k];
    if (!t.valid) continue;
    const Eigen::Matrix3d leverage = t.J_x * P_x * t.J_x.transpose();
    Eigen::LLT<Eigen::Matrix3d> C(kept[k] ? Eigen::Matrix3d(t.S - leverage)
                                          : Eigen::Matrix3d(t.S + leverage));
    // A kept observation the pose hangs on alone has no residual to test (C singular).
    if (C.info() != Eigen::Success) C.compute(t.S);
    t.d2 = t.r.dot(C.solve(t.r));
  }
}

// The kept set's normalised innovation squared after the pose's GLS fit, with the features'
// joint covariance, and its degrees of freedom (3 per observation, less the pose's 6); false
// when that covariance is not positive definite (numerically), and the set cannot be tested.
bool JointNis(const std::vector<Term>& terms, const std::vector<bool>& kept,
              const std::vector<FeatureObservation>& observations, const FeatureCovariance& known,
              int* dof, double* nis) {
  std::vector<int> index;
  for (size_t k = 0; k < terms.size(); ++k) {
    if (kept[k]) index.push_back(static_cast<int>(k));
  }
  const int n = static_cast<int>(index.size());
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(3 * n, 6);
  Eigen::VectorXd r(3 * n);
  for (int a = 0; a < n; ++a) {
    const Term& ta = terms[index[a]];
    S.block<3, 3>(3 * a, 3 * a) += observations[ta.input].Q;
    J.block<3, 6>(3 * a, 0) = ta.J_x;
    r.segment<3>(3 * a) = ta.r;
    for (int b = 0; b <= a; ++b) {
      const Term& tb = terms[index[b]];
      const Eigen::Matrix3d block =
          ta.J_f * known.covariance.block<3, 3>(3 * ta.block, 3 * tb.block) * tb.J_f.transpose();
      S.block<3, 3>(3 * a, 3 * b) += block;
      if (b != a) S.block<3, 3>(3 * b, 3 * a) += block.transpose();
    }
  }
  *dof = 3 * n - 6;
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::VectorXd Si_r = llt.solve(r);
  const Eigen::MatrixXd Si_J = llt.solve(J);
  const Matrix6d H = J.transpose() * Si_J;
  const Vector6d g = J.transpose() * Si_r;
  *nis = r.dot(Si_r) - g.dot(H.ldlt().solve(g));
  return std::isfinite(*nis);
}

// Gauss-Newton of the pose on the kept set to convergence from *T, then each term's residual
// test against that fit (Studentize). When the kept set does not determine the pose, *T is
// left as it was and the terms hold their plain residuals against it. True when fitted.
bool FitKept(const InformationFilter& filter, const std::vector<FeatureObservation>& obs,
             const FeatureCovariance& known, const std::vector<bool>& kept, Vector6d* T,
             std::vector<Term>* terms, Matrix6d* P_x) {
  const Vector6d T_start = *T;
  Vector6d step;
  std::vector<double> weight(terms->size(), 0.0);
  bool fitted = false;
  bool converged = false;
  for (int it = 0; it < kFitIterations && !converged; ++it) {
    Linearize(filter, *T, obs, known, terms);
    for (size_t k = 0; k < terms->size(); ++k) weight[k] = kept[k] && (*terms)[k].valid;
    Matrix6d P;
    if (!PoseStep(*terms, weight, &step, &P)) break;
    *T += step;
    fitted = true;
    converged = step.norm() < kConverged;
  }
  Linearize(filter, *T, obs, known, terms);
  if (fitted) {
    // P_x at the final linearisation point, for the residual tests.
    for (size_t k = 0; k < terms->size(); ++k) weight[k] = kept[k] && (*terms)[k].valid;
    fitted = PoseStep(*terms, weight, &step, P_x);
    if (fitted) Studentize(kept, *P_x, terms);
  }
  if (!fitted) {
    *T = T_start;
    Linearize(filter, *T, obs, known, terms);
  }
  return fitted;
}

// Fits the pose robustly from *T (Cauchy weights at the gate's scale keep gross outliers
// from dragging the pose they are then tested against) and takes the first kept set from
// that fit; then refits on the kept set and gates again until the set stops changing. False
// when the pose could not be fitted (the terms are then tested against the initial pose).
bool GateSingly(const InformationFilter& filter, const std::vector<FeatureObservation>& obs,
                const FeatureCovariance& known, double gate, Vector6d* T, std::vector<Term>* terms,
                std::vector<bool>* kept, Matrix6d* P_x) {
  Vector6d step;
  Matrix6d P;
  std::vector<double> weight(terms->size(), 1.0);
  const Vector6d T_initial = *T;
  bool robust = false;
  for (int it = 0; it < kRobustIterations; ++it) {
    Linearize(filter, *T, obs, known, terms);
    for (size_t k = 0; k < terms->size(); ++k) weight[k] = 1.0 / (1.0 + (*terms)[k].d2 / gate);
    if (!PoseStep(*terms, weight, &step, &P)) break;
    *T += step;
    robust = true;
  }
  if (!robust) *T = T_initial;
  Linearize(filter, *T, obs, known, terms);
  kept->resize(terms->size());
  for (size_t k = 0; k < terms->size(); ++k) {
    (*kept)[k] = (*terms)[k].valid && (!robust || (*terms)[k].d2 <= gate);
  }
  bool fitted = false;
  for (int round = 0; round < kGateRounds; ++round) {
    if (!FitKept(filter, obs, known, *kept, T, terms, P_x)) {
      // The kept set does not determine the pose: test against the last fit (or the
      // initial pose) without a fit's leverage.
      for (size_t k = 0; k < terms->size(); ++k) {
        (*kept)[k] = (*terms)[k].valid && (*terms)[k].d2 <= gate;
      }
      break;
    }
    fitted = true;
    bool changed = false;
    for (size_t k = 0; k < terms->size(); ++k) {
      const bool keep = (*terms)[k].valid && (*terms)[k].d2 <= gate;
      changed = changed || keep != (*kept)[k];
      (*kept)[k] = keep;
    }
    if (!changed) break;
  }
  return fitted || robust;
}

// The joint test of the kept set (see the header): first Q scaled by the frame's variance
// factor and the single gates taken again, then the worst observation dropped, with a refit
// after each, until the set passes. Updates the observations' Q, the pose, the terms, the
// kept set, P_x, *noise_scale and the counts; true when it fitted a pose.
bool TestJointly(const InformationFilter& filter, const FeatureCovariance& known,
                 std::vector<FeatureObservation>* obs, Vector6d* T, std::vector<Term>* terms,
                 std::vector<bool>* kept, Matrix6d* P_x, double* noise_scale,
                 GateStatistics* stats) {
  const InformationFilterOptions& options = filter.options();
  bool fitted = false;
  int dof = 0;
  double nis = 0.0;
  // Each test is a dense factorisation of the kept set's 3n x 3n innovation covariance, most
  // of the gate's cost: the set is tested once as it stands and once after each change.
  bool testable = JointNis(*terms, *kept, *obs, known, &dof, &nis);
  const auto fails = [&] {
    return testable && dof > 0 && nis > ChiSquareQuantile(options.joint_probability, dof);
  };
  // A set that fails the joint test as a whole says the frame's noise is larger than Q
  // claims (blur, a colour/depth time offset under fast motion): its variance factor, the
  // NIS per degree of freedom, scales the frame's Q (never below the prior), and the
  // single gates are taken again at that scale. The factor is that of the whole innovation
  // covariance Q + J_f P_f J_f^T while only Q is scaled, so where the map's share matters
  // one scaling falls short; the gates truncate the tails it is estimated from too. Hence
  // it is re-estimated on the new kept set until the set passes.
  for (int round = 0; options.adapt_noise && round < kNoiseRounds && fails(); ++round) {
    const double scale = std::min(nis / dof, options.max_noise_scale / *noise_scale);
    if (!(scale > 1.0)) break;
    for (FeatureObservation& o : *obs) o.Q *= scale;
    *noise_scale *= scale;
    fitted = GateSingly(filter, *obs, known, options.gate_chi2, T, terms, kept, P_x) || fitted;
    testable = JointNis(*terms, *kept, *obs, known, &dof, &nis);
  }
  // Then the worst observation against the fit of the rest goes, and the rest is refitted,
  // until the set passes.
  for (; fails(); ++stats->rejected_joint) {
    if (stats->rejected_joint == kMaxJointDrops ||
        std::count(kept->begin(), kept->end(), true) <= options.min_known_features) {
      stats->incompatible_frames = 1;
      break;
    }
    size_t worst = 0;
    double worst_d2 = -1.0;
    for (size_t k = 0; k < terms->size(); ++k) {
      if ((*kept)[k] && (*terms)[k].d2 > worst_d2) worst_d2 = (*terms)[k].d2, worst = k;
    }
    (*kept)[worst] = false;
    FitKept(filter, *obs, known, *kept, T, terms, P_x);
    testable = JointNis(*terms, *kept, *obs, known, &dof, &nis);
  }
  if (!testable) stats->incompatible_frames = 1;
  stats->noise_scales.push_back(*noise_scale);
  return fitted;
}

}  // namespace

void GateStatistics::Add(const GateStatistics& other) {
  frames += other.frames;
  tested += other.tested;
  rejected += other.rejected;
  rejected_joint += other.rejected_joint;
  incompatible_frames += other.incompatible_frames;
  noise_scales.insert(noise_scales.end(), other.noise_scales.begin(), other.noise_scales.end());
}

GatedObservations GateObservations(const InformationFilter& filter, const Vector6d& T_w_c_initial,
                                   const std::vector<FeatureObservation>& observations,
                                   const FeatureCovariance& known, bool joint) {
  GatedObservations out;
  out.T_w_c = T_w_c_initial;
  out.stats.frames = 1;
  const InformationFilterOptions& options = filter.options();
  std::vector<Term> terms;
  for (size_t i = 0; i < observations.size(); ++i) {
    const auto it = known.index.find(observations[i].feature_id);
    // A pending feature is tested where `known` holds it (JointFeatureCovariance holds only
    // known and pending ones), as the filter holding it since its first sighting would test
    // it; a feature no pose has seen cannot be.
    if (!filter.HasFeature(observations[i].feature_id) && it == known.index.end()) continue;
    CHECK(it != known.index.end())
        << "feature " << observations[i].feature_id << " is missing from the FeatureCovariance";
    Term t;
    t.input = static_cast<int>(i);
    t.block = it->second;
    terms.push_back(t);
  }
  out.stats.tested = static_cast<int>(terms.size());
  if (options.gate_chi2 <= 0.0 || terms.empty()) {
    out.observations = observations;
    return out;
  }

  std::vector<FeatureObservation> obs = observations;
  Vector6d T = T_w_c_initial;
  std::vector<bool> kept;
  Matrix6d P_x = Matrix6d::Zero();
  bool fitted = GateSingly(filter, obs, known, options.gate_chi2, &T, &terms, &kept, &P_x);
  if (joint && options.joint_compatibility) {
    fitted =
        TestJointly(filter, known, &obs, &T, &terms, &kept, &P_x, &out.noise_scale, &out.stats) ||
        fitted;
  }

  std::vector<bool> keep_input(obs.size(), true);
  for (size_t k = 0; k < terms.size(); ++k) {
    if (!kept[k]) {
      keep_input[terms[k].input] = false;
      ++out.stats.rejected;
    }
  }
  for (size_t i = 0; i < obs.size(); ++i) {
    if (keep_input[i]) out.observations.push_back(obs[i]);
  }
  out.pose_fitted = fitted && T.allFinite();
  if (out.pose_fitted) out.T_w_c = T;
  return out;
}

}  // namespace ieslam
