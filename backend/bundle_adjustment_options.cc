// The bundle adjustment's option names and their registration (bundle_adjustment.h).
#include <string>

#include "backend/bundle_adjustment.h"

namespace ieslam {

std::string BaRobustLossName(BaRobustLoss loss) {
  return loss == BaRobustLoss::kHuber ? "huber" : "none";
}

bool ParseBaRobustLoss(const std::string& name, BaRobustLoss* loss) {
  for (const BaRobustLoss candidate : {BaRobustLoss::kNone, BaRobustLoss::kHuber}) {
    if (name == BaRobustLossName(candidate)) {
      *loss = candidate;
      return true;
    }
  }
  return false;
}

std::string BaCovarianceName(BaCovariance method) {
  return method == BaCovariance::kSchur ? "schur" : "sparse_qr";
}

std::string BaLinearSolverName(BaLinearSolver solver) {
  switch (solver) {
    case BaLinearSolver::kAuto:
      return "auto";
    case BaLinearSolver::kDenseSchur:
      return "dense_schur";
    case BaLinearSolver::kSparseSchur:
      return "sparse_schur";
    case BaLinearSolver::kSparseNormalCholesky:
      break;
  }
  return "sparse_normal_cholesky";
}

namespace {

bool ParseBaCovariance(const std::string& name, BaCovariance* method) {
  for (const BaCovariance candidate : {BaCovariance::kSchur, BaCovariance::kSparseQr}) {
    if (name == BaCovarianceName(candidate)) {
      *method = candidate;
      return true;
    }
  }
  return false;
}

bool ParseBaLinearSolver(const std::string& name, BaLinearSolver* solver) {
  for (const BaLinearSolver candidate :
       {BaLinearSolver::kAuto, BaLinearSolver::kDenseSchur, BaLinearSolver::kSparseSchur,
        BaLinearSolver::kSparseNormalCholesky}) {
    if (name == BaLinearSolverName(candidate)) {
      *solver = candidate;
      return true;
    }
  }
  return false;
}

}  // namespace

const OptionTable<BundleAdjustmentOptions>& BundleAdjustmentOptions::Table() {
  static const OptionTable<BundleAdjustmentOptions>* table = [] {
    using O = BundleAdjustmentOptions;
    auto* t = new OptionTable<O>;
    t->Enum("robust_loss", &O::robust_loss, ParseBaRobustLoss, BaRobustLossName, "none|huber",
            "loss on the whitened residuals");
    t->Double("huber_scale", &O::huber_scale, "sigmas: Huber's quadratic part");
    t->Double("rejection_chi2", &O::rejection_chi2,
              "drop observations with |W (h - z)|^2 above this and solve again (0: keep all)")
        .Min(0.0);
    t->Int("max_rejection_rounds", &O::max_rejection_rounds,
           "solves after rejections (or a new weight of the relative poses) at most")
        .Min(0);
    t->Bool("weigh_relative_poses", &O::weigh_relative_poses,
            "relative poses' information divided by their own variance factor");
    t->Bool("refine_registered", &O::refine_registered,
            "the refinement weighs every registered observation, not the filter's gated set");
    t->Bool("estimate_depth_correction", &O::estimate_depth_correction,
            "the refinement estimates the range imager's depth_correction (corrected_calib.yaml)");
    t->Bool("apply_depth_correction", &O::apply_depth_correction,
            "the refinement is made again with the estimated correction applied to every range");
    t->Int("max_iterations", &O::max_iterations, "Levenberg-Marquardt iterations per solve").Min(1);
    t->Double("cost_tolerance", &O::cost_tolerance,
              "a step's gain or its model's miss below this ends a solve (1/2 chi-square; 0: off)")
        .Min(0.0);
    t->Double("function_tolerance", &O::function_tolerance,
              "relative cost decrease below which a solve stops")
        .Min(0.0);
    t->Double("gradient_tolerance", &O::gradient_tolerance, "Ceres' gradient tolerance").Min(0.0);
    t->Double("parameter_tolerance", &O::parameter_tolerance, "Ceres' parameter tolerance")
        .Min(0.0);
    t->Double("initial_trust_region_radius", &O::initial_trust_region_radius,
              "Levenberg-Marquardt's first trust region (its reciprocal: the first damping)")
        .Range(1e-32, 1e16);  // Ceres' minimum and maximum trust region
    t->Enum("linear_solver", &O::linear_solver, ParseBaLinearSolver, BaLinearSolverName,
            "auto|dense_schur|sparse_schur|sparse_normal_cholesky",
            "Ceres' linear solver (auto: dense Schur for few poses or a full system)");
    t->Int("num_threads", &O::num_threads, "Ceres' threads: from the run's threads")
        .Min(1)
        .Derived();
    t->Bool("compute_covariances", &O::compute_covariances, "per-pose marginal covariances");
    t->Enum("covariance_method", &O::covariance_method, ParseBaCovariance, BaCovarianceName,
            "schur|sparse_qr", "how: features eliminated (exact, fast) or ceres::Covariance");
    t->Double("min_depth_m", &O::min_depth_m, "a point closer to the camera plane is invalid")
        .Above(0.0);
    t->Require([](const O& o) {
      return o.robust_loss != BaRobustLoss::kHuber || o.huber_scale > 0.0
                 ? std::string()
                 : "huber_scale must be > 0 with robust_loss huber";
    });
    t->Require([](const O& o) {
      return !o.apply_depth_correction || o.estimate_depth_correction
                 ? std::string()
                 : "apply_depth_correction needs estimate_depth_correction: 1";
    });
    return t;
  }();
  return *table;
}

}  // namespace ieslam
