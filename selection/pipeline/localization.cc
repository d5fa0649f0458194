#include "selection/pipeline/localization.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <unordered_map>
#include <utility>

#include <glog/logging.h>
#include <Eigen/Cholesky>

#include "backend/evaluation/evaluation.h"
#include "core/error.h"
#include "core/stopwatch.h"
#include "frontend/frame_prefetcher.h"
#include "frontend/rolling_shutter.h"

namespace ieslam {
namespace {

// d(pose of T_a_c)/d(pose of T_a_b) for T_a_c = T_a_b * T_b_c on core/pose.h's 6-vectors, by
// central differences (angles are smooth away from gimbal lock, where the map's own
// covariances are not defined either).
Matrix6d ComposeJacobianFirst(const Vector6d& T_a_b, const Vector6d& T_b_c) {
  constexpr double kStep = 1e-6;
  Matrix6d J;
  for (int k = 0; k < 6; ++k) {
    Vector6d plus = T_a_b, minus = T_a_b;
    plus[k] += kStep;
    minus[k] -= kStep;
    J.col(k) = PoseDifference(ComposePoses(plus, T_b_c), ComposePoses(minus, T_b_c)) / (2 * kStep);
  }
  return J;
}

// The information of the 6-vector pose of T_map_c from its inlier correspondences
// (p_map = R p_c + t), each weighted by its two points' covariance.
Matrix6d FitInformation(const Eigen::Isometry3d& T_map_c,
                        const std::vector<MapLocalizer::PoolEntry>& pool,
                        const std::vector<int>& inliers, const ProcessedFrame& frame) {
  constexpr double kStep = 1e-6;
  const Vector6d pose = IsometryToPose(T_map_c);
  const Eigen::Matrix3d R = T_map_c.linear();
  Eigen::Matrix3d dR[3];
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = pose.tail<3>(), minus = pose.tail<3>();
    plus[k] += kStep;
    minus[k] -= kStep;
    dR[k] = (EulerZyxToRotation(plus) - EulerZyxToRotation(minus)) / (2 * kStep);
  }
  Matrix6d information = Matrix6d::Zero();
  for (int i : inliers) {
    const MapLocalizer::PoolEntry& e = pool[i];
    const LiftedPoint& p = frame.points[e.row];
    Eigen::Matrix<double, 3, 6> J;
    J.leftCols<3>().setIdentity();
    for (int k = 0; k < 3; ++k) J.col(3 + k) = dR[k] * p.p_c;
    const Eigen::Matrix3d S = e.cov_map + R * p.p_c_covariance * R.transpose();
    information += J.transpose() * S.ldlt().solve(J);
  }
  return information;
}

// The frames of a dataset in order, as the front end makes them, each moved into the view of
// its timestamp when the rig has a rolling shutter (frontend/rolling_shutter.h): its velocity
// comes from its registrations to the frames before and after it, so one frame is taken
// ahead. A frame that does not load keeps its error for when it is asked for.
class LocalizedFrameSource {
 public:
  LocalizedFrameSource(const Dataset& dataset, const FrameProcessor& processor,
                       const PrefetchOptions& prefetch, const FrontendOptions& frontend,
                       double velocity_max_step_s, LocalizeTimings* seconds)
      : dataset_(dataset),
        frontend_(frontend),
        prefetcher_(dataset, processor, prefetch),
        seconds_(seconds) {
    if (dataset.rig().colour_readout_s != 0.0) {
      std::vector<double> timestamps;
      for (int i = 0; i < dataset.size(); ++i) timestamps.push_back(dataset.info(i).timestamp);
      velocities_ = std::make_unique<FrameVelocities>(std::move(timestamps), velocity_max_step_s);
    }
  }

  // Frame i; frames are asked for in increasing order. Throws DataError as Dataset::Load does.
  PrefetchedFrame Take(int i) {
    // A copy: frame i as the front end made it stays for frame i + 1's step.
    PrefetchedFrame taken = Fetch(i).frame;
    const std::string error = Fetch(i).error;
    if (!error.empty()) throw DataError(error);
    if (velocities_ && taken.has_valid_depth && taken.processed.features.size() > 0) {
      const std::optional<CameraVelocity> velocity =
          velocities_->Of(i, [this](int later) { return RegisterStep(later); });
      ProcessedFrame& frame = taken.processed;
      for (size_t k = 0; velocity && k < frame.points.size(); ++k) {
        frame.points[k] = CompensateRollingShutter(frame.points[k], frame.features.pixels[k].y(),
                                                   *velocity, dataset_.rig());
      }
    }
    held_.erase(held_.begin(), held_.lower_bound(i));
    return taken;
  }

  const FrameVelocities* velocities() const { return velocities_.get(); }

 private:
  struct Held {
    PrefetchedFrame frame;
    std::string error;  // a frame that did not load
  };

  // Frame i as the front end made it, taken once from the prefetcher and held.
  Held& Fetch(int i) {
    auto it = held_.find(i);
    if (it != held_.end()) return it->second;
    Held held;
    const auto start = std::chrono::steady_clock::now();
    try {
      held.frame = prefetcher_.Take(i);
      seconds_->load += held.frame.seconds_load;
      seconds_->extract += held.frame.processed.seconds_extract;
      seconds_->lift += held.frame.processed.seconds_lift;
      held.frame.processed.info = dataset_.info(i);
    } catch (const DataError& e) {
      held.error = e.what();
    }
    seconds_->fetch_wall += SecondsSince(start);
    return held_.emplace(i, std::move(held)).first->second;
  }

  std::optional<Eigen::Isometry3d> RegisterStep(int later) {
    const ProcessedFrame& a = Fetch(later - 1).frame.processed;
    const ProcessedFrame& b = Fetch(later).frame.processed;
    return StepMotion(a, b, frontend_, &seconds_->match, &seconds_->ransac);
  }

  const Dataset& dataset_;
  const FrontendOptions& frontend_;
  FramePrefetcher prefetcher_;
  LocalizeTimings* seconds_;
  std::unique_ptr<FrameVelocities> velocities_;  // rolling-shutter rigs only
  std::map<int, Held> held_;
};

}  // namespace

const OptionTable<LocalizeOptions>& LocalizeOptions::Table() {
  static const OptionTable<LocalizeOptions>* table = [] {
    using O = LocalizeOptions;
    auto* t = new OptionTable<O>;
    t->Int("candidates", &O::candidates,
           "base frames the database ranks first that a frame is registered to")
        .Range(1, 64);
    t->Int("min_inliers_secondary", &O::min_inliers_secondary,
           "inliers a base frame other than the best needs to add its matches")
        .Min(3);
    t->Int("track_inliers", &O::track_inliers,
           "inliers to the base frame that placed the frame before that spare the database")
        .Min(1);
    t->Int("max_tracked_frames", &O::max_tracked_frames,
           "frames, placed or not, after the map last placed one that tracking may place (0: none)")
        .Min(0);
    t->Bool("refined_poses", &O::refined_poses,
            "place frames against the map's refined keyframes when it has them");
    return t;
  }();
  return *table;
}

MapLocalizer::MapLocalizer(const SavedMap& map, const FrontendOptions& frontend,
                           const DatabaseOptions& database, const LocalizeOptions& options)
    : map_(map), frontend_(frontend), options_(options), database_(database) {
  std::string why;
  if (!frontend_.Check(&why) || !options_.Check(&why)) throw ConfigError(why);
  CHECK_EQ(map.base_frames.size(), map.keyframes.size());
  std::unordered_map<int64_t, int> index_of;
  for (size_t i = 0; i < map.features.size(); ++i) {
    index_of.emplace(map.features[i].id, static_cast<int>(i));
  }
  base_feature_index_.resize(map.base_frames.size());
  for (size_t b = 0; b < map.base_frames.size(); ++b) {
    for (int64_t id : map.base_frames[b].feature_ids) {
      const auto it = index_of.find(id);
      base_feature_index_[b].push_back(it == index_of.end() ? -1 : it->second);
    }
  }
  refined_ = options_.refined_poses && !map.keyframes.empty() &&
             std::all_of(map.keyframes.begin(), map.keyframes.end(),
                         [](const MapKeyframe& k) { return k.refined; });
  bases_.resize(map.base_frames.size());
  for (size_t k = 0; k < map.base_frames.size(); ++k) {
    const MapBaseFrame& b = map.base_frames[k];
    FrameInfo info;
    info.index = b.frame;
    info.timestamp = b.timestamp;
    bases_[k] = ProcessedBaseFrame(b, info);
    const MapKeyframe& keyframe = map.keyframes[k];
    base_poses_.push_back(PoseToIsometry(refined_ ? keyframe.refined_pose : keyframe.pose));
    if (b.features.size() > 0) database_.Add(static_cast<int>(k), b.features.descriptors);
  }
}

MapLocalizer::~MapLocalizer() = default;

std::vector<int> MapLocalizer::Candidates(const ProcessedFrame& frame) {
  ++database_queries_;
  std::vector<int> bases;
  if (database_.num_frames() > 0) {
    for (const auto& [base, votes] :
         database_.RankFrames(frame.features.descriptors, options_.candidates)) {
      bases.push_back(base);
    }
  }
  if (last_base_ >= 0 && std::find(bases.begin(), bases.end(), last_base_) == bases.end()) {
    bases.push_back(last_base_);
  }
  return bases;
}

std::vector<std::pair<int, FrameRegistration>> MapLocalizer::RegisterToMap(
    const ProcessedFrame& frame) {
  std::vector<std::pair<int, FrameRegistration>> registered;
  auto try_base = [&](int base) {
    FrameRegistration r =
        RegisterFrames(bases_[base], frame, frontend_.matching, frontend_.registration);
    seconds_match_ += r.seconds_match;
    seconds_ransac_ += r.seconds_ransac;
    const int inliers = r.result.success ? static_cast<int>(r.result.inliers.size()) : 0;
    if (r.result.success) registered.emplace_back(base, std::move(r));
    return inliers;
  };
  // While the map placed the frame before, the base frame that did so usually places this one
  // as well, and the database is asked only when it does not register well.
  const bool tracking = has_previous_ && since_map_ == 1 && last_base_ >= 0;
  if (!tracking || try_base(last_base_) < options_.track_inliers) {
    const auto start = std::chrono::steady_clock::now();
    const std::vector<int> ranked = Candidates(frame);
    seconds_match_ += SecondsSince(start);
    for (int base : ranked) {
      if (!tracking || base != last_base_) try_base(base);
    }
  }
  std::stable_sort(registered.begin(), registered.end(), [](const auto& a, const auto& b) {
    return a.second.result.inliers.size() > b.second.result.inliers.size();
  });
  return registered;
}

void MapLocalizer::AddToPool(int base, const FrameRegistration& registration,
                             const ProcessedFrame& frame, std::vector<PoolEntry>* pool,
                             std::vector<char>* pooled) const {
  const bool previous = base == kPrevious;
  const ProcessedFrame& b = previous ? previous_ : bases_[base];
  const Eigen::Isometry3d& T_map_b = previous ? previous_pose_ : base_poses_[base];
  for (int i : registration.result.inliers) {
    const DescriptorMatch& m = registration.matches[i];
    if ((*pooled)[m.query]) continue;
    (*pooled)[m.query] = 1;
    PoolEntry e;
    e.row = m.query;
    e.map = !previous;
    const LiftedPoint& q = b.points[m.train];
    const int f = previous ? -1 : base_feature_index_[base][m.train];
    e.feature = f >= 0;
    e.p_map = e.feature && !refined_ ? map_.features[f].p_w : T_map_b * q.p_c;
    e.cov_map = T_map_b.linear() * q.p_c_covariance * T_map_b.linear().transpose();
    e.sigma_d = std::sqrt(q.Q(2, 2) + frame.points[m.query].Q(2, 2));
    pool->push_back(e);
  }
}

LocalizedFrame MapLocalizer::Localize(const ProcessedFrame& frame) {
  LocalizedFrame out;
  out.frame = frame.info.index;
  out.timestamp = frame.info.timestamp;
  ++since_map_;
  const std::vector<std::pair<int, FrameRegistration>> registered = RegisterToMap(frame);

  // The map's pool: each frame keypoint once, from the best registration that has it.
  auto start = std::chrono::steady_clock::now();
  std::vector<PoolEntry> pool;
  std::vector<char> pooled(frame.features.size(), 0);
  for (size_t r = 0; r < registered.size(); ++r) {
    const auto& [base, reg] = registered[r];
    if (r > 0 && static_cast<int>(reg.result.inliers.size()) < options_.min_inliers_secondary) {
      continue;
    }
    ++out.base_frames_registered;
    AddToPool(base, reg, frame, &pool, &pooled);
  }
  // The frame placed before adds its matches after the map's, which keep precedence: where
  // the map's views are narrow or few, its many close matches steady the fit, and where the
  // map has none they place the frame alone (tracking).
  const int map_rows = static_cast<int>(pool.size());
  seconds_ransac_ += SecondsSince(start);
  if (has_previous_) {
    FrameRegistration r =
        RegisterFrames(previous_, frame, frontend_.matching, frontend_.registration);
    seconds_match_ += r.seconds_match;
    seconds_ransac_ += r.seconds_ransac;
    if (r.result.success) {
      ++out.base_frames_registered;
      AddToPool(kPrevious, r, frame, &pool, &pooled);
    }
  }
  start = std::chrono::steady_clock::now();
  RegistrationResult result;
  if (!pool.empty()) result = FitPool(pool, frame);
  seconds_ransac_ += SecondsSince(start);
  int map_inliers = 0;
  for (int i : result.inliers) map_inliers += i < map_rows ? 1 : 0;
  out.by_map = result.success && map_inliers >= frontend_.registration.min_inliers;
  if (!result.success) {
    out.reason = registered.empty() ? "registered to none of the map's best-ranked base frames"
                                    : "the matches of " + std::to_string(registered.size()) +
                                          " base frames that registered do not agree on a pose";
    if (has_previous_) out.reason += ", nor to the frame placed before it";
    return out;
  }
  if (!out.by_map && since_map_ > options_.max_tracked_frames) {
    out.reason = "placed only by tracking, " + std::to_string(since_map_) +
                 " frames after the map last placed one (at most " +
                 std::to_string(options_.max_tracked_frames) + ")";
    has_previous_ = false;
    return out;
  }
  Place(result, pool, frame, registered.empty() ? -1 : registered.front().first, &out);
  return out;
}

void MapLocalizer::Place(const RegistrationResult& result, const std::vector<PoolEntry>& pool,
                         const ProcessedFrame& frame, int best, LocalizedFrame* out) {
  out->localized = true;
  out->T_map_c = result.T_a_b;
  out->inliers = static_cast<int>(result.inliers.size());
  for (int i : result.inliers) {
    out->map_inliers += pool[i].map ? 1 : 0;
    out->map_features += pool[i].feature ? 1 : 0;
  }
  // The pose's error is the fit's plus what it inherits from the pose it was placed against:
  // the best base keyframe's, or the previous frame's when tracked. Placed by the map, the
  // fit's information is its map inliers' alone: the previous frame's matches steady the
  // pose, but they know the map only through the same keyframes, so they add nothing new.
  const Eigen::Isometry3d& T_map_anchor = out->by_map ? base_poses_[best] : previous_pose_;
  const Matrix6d& anchor_covariance =
      out->by_map ? map_.keyframes[best].covariance : previous_covariance_;
  out->base_keyframe = out->by_map ? best : -1;
  std::vector<int> informative;
  for (int i : result.inliers) {
    if (!out->by_map || pool[i].map) informative.push_back(i);
  }
  const Matrix6d information = FitInformation(out->T_map_c, pool, informative, frame);
  const Matrix6d J = ComposeJacobianFirst(IsometryToPose(T_map_anchor),
                                          IsometryToPose(T_map_anchor.inverse() * out->T_map_c));
  out->covariance =
      information.ldlt().solve(Matrix6d::Identity()) + J * anchor_covariance * J.transpose();
  out->covariance = 0.5 * (out->covariance + out->covariance.transpose()).eval();
  if (out->by_map) {
    last_base_ = best;
    since_map_ = 0;
  }
  previous_ = frame;
  previous_pose_ = out->T_map_c;
  previous_covariance_ = out->covariance;
  has_previous_ = true;
}

RegistrationResult MapLocalizer::FitPool(const std::vector<PoolEntry>& pool,
                                         const ProcessedFrame& frame) const {
  // One RANSAC over the pool, with the inlier distance the pairwise registrations use.
  std::vector<Eigen::Vector3d> points_map, points_c;
  std::vector<Eigen::Matrix3d> cov_map, cov_c;
  std::vector<double> sigmas;
  for (const PoolEntry& e : pool) {
    points_map.push_back(e.p_map);
    points_c.push_back(frame.points[e.row].p_c);
    cov_map.push_back(e.cov_map);
    cov_c.push_back(frame.points[e.row].p_c_covariance);
    sigmas.push_back(e.sigma_d);
  }
  RegistrationOptions fit = frontend_.registration;
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  fit.inlier_threshold_m =
      std::max(fit.inlier_threshold_m, fit.inlier_noise_sigmas * sigmas[sigmas.size() / 2]);
  return fit.use_point_covariances ? RegisterPointSets(points_map, points_c, cov_map, cov_c, fit)
                                   : RegisterPointSets(points_map, points_c, fit);
}

LocalizeResult LocalizeDataset(const Dataset& dataset, const SavedMap& map,
                               const RgbdSourceOptions& source, const LocalizeOptions& options,
                               const LocalizeHooks& hooks) {
  const auto start = std::chrono::steady_clock::now();
  LocalizeResult out;
  const FrontendOptions& frontend = source.frontend;
  MapLocalizer localizer(map, frontend, source.database, options);
  out.seconds.setup = SecondsSince(start);
  const FrameProcessor processor(dataset.rig(), frontend);
  LocalizedFrameSource frames(dataset, processor, source.prefetch, frontend,
                              source.velocity_max_step_s, &out.seconds);
  bool lost = false;
  for (int i = 0; i < dataset.size(); ++i) {
    if (hooks.stop && hooks.stop()) {
      out.interrupted = true;
      break;
    }
    const FrameInfo& info = dataset.info(i);
    const std::string name = "frame " + std::to_string(info.source_index) + ": ";
    LocalizedFrame placed;
    placed.frame = i;
    placed.timestamp = info.timestamp;
    try {
      PrefetchedFrame fetched = frames.Take(i);
      const int needed = frontend.registration.min_inliers;
      if (!fetched.has_valid_depth) {
        placed.reason = name + "range image " + info.depth_path + " has no valid measurement";
      } else if (fetched.processed.features.size() < needed) {
        placed.reason = name +
                        "too little texture: " + std::to_string(fetched.processed.features.size()) +
                        " keypoints lifted, registration needs " + std::to_string(needed);
      } else {
        placed = localizer.Localize(fetched.processed);
        if (!placed.localized) placed.reason = name + placed.reason;
      }
    } catch (const DataError& e) {
      placed.reason = e.what();  // Load's messages name the frame and the file
    }
    if (placed.localized) {
      ++out.localized;
      out.localized_by_map += placed.by_map ? 1 : 0;
      if (lost) ++out.resumptions;
    }
    lost = !placed.localized;
    out.frames.push_back(std::move(placed));
    if (hooks.progress) hooks.progress(i + 1, out.localized);
  }
  out.refined_poses = localizer.uses_refined_poses();
  out.database_queries = localizer.database_queries();
  out.seconds.match += localizer.seconds_match();
  out.seconds.ransac += localizer.seconds_ransac();
  if (frames.velocities() != nullptr) out.velocity_counts = frames.velocities()->counts();
  out.seconds.total = SecondsSince(start);
  return out;
}

MapFrameAlignment AlignMapToGroundTruth(const SavedMap& map, bool refined) {
  MapFrameAlignment out;
  if (!map.keyframes.empty() && map.keyframes.front().has_ground_truth) {
    const MapKeyframe& k = map.keyframes.front();
    out.has_origin = true;
    out.T_map_gt_origin = PoseToIsometry(refined ? k.refined_pose : k.pose) *
                          PoseToIsometry(k.ground_truth).inverse();
  }
  std::vector<Eigen::Vector3d> p_map, p_gt;
  for (const MapKeyframe& k : map.keyframes) {
    if (!k.has_ground_truth) continue;
    p_map.push_back((refined ? k.refined_pose : k.pose).head<3>());
    p_gt.push_back(k.ground_truth.head<3>());
  }
  out.keyframes = static_cast<int>(p_map.size());
  if (p_map.size() < 3) {
    out.reason =
        std::to_string(p_map.size()) + " of the map's keyframes have ground truth (3 are needed)";
    return out;
  }
  out.T_map_gt = AlignHorn(p_gt, p_map);
  double sum = 0.0;
  for (size_t i = 0; i < p_map.size(); ++i) {
    sum += (out.T_map_gt * p_gt[i] - p_map[i]).squaredNorm();
  }
  out.rmse_m = std::sqrt(sum / static_cast<double>(p_map.size()));
  out.ok = true;
  return out;
}

}  // namespace ieslam
