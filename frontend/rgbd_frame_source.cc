#include "frontend/rgbd_frame_source.h"

#include <algorithm>
#include <chrono>
#include <string>

#include <glog/logging.h>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/parallel_for.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

FeatureObservation ObservationOf(const LiftedPoint& point, int64_t id) {
  FeatureObservation obs;
  obs.feature_id = id;
  obs.z = point.z;
  obs.Q = point.Q;
  return obs;
}

// SIFT gives a blob with more than one dominant gradient direction one keypoint per
// direction: same position, scale and response, a descriptor each (ExtractFeatures keeps
// them in consecutive rows). They are one image measurement, so they make one feature and
// one observation; their descriptors are alternatives for matching. Returns, for each row,
// the first row of its group.
std::vector<int> SiblingGroups(const FrameFeatures& features) {
  std::vector<int> first(features.size());
  for (int row = 0; row < features.size(); ++row) {
    const bool sibling = row > 0 && features.pixels[row] == features.pixels[row - 1] &&
                         features.scales[row] == features.scales[row - 1];
    first[row] = sibling ? first[row - 1] : row;
  }
  return first;
}

}  // namespace

const OptionTable<RgbdSourceOptions>& RgbdSourceOptions::Table() {
  static const OptionTable<RgbdSourceOptions>* table = [] {
    using O = RgbdSourceOptions;
    auto* t = new OptionTable<O>;
    t->Int("max_base_candidates", &O::max_base_candidates,
           "base frames ranked by the database that are registered")
        .Min(1);
    t->Int("max_new_features_per_frame", &O::max_new_features_per_frame,
           "new features a selected frame adds at most")
        .Min(0);
    t->Int("min_inliers_secondary", &O::min_inliers_secondary,
           "inliers another base frame's observations need");
    t->Double("velocity_max_step_s", &O::velocity_max_step_s,
              "rolling shutter: frames further apart in time give no velocity")
        .Above(0.0);
    t->Require([](const O& o) {
      return o.min_inliers_secondary >= o.frontend.registration.min_inliers
                 ? std::string()
                 : "min_inliers_secondary must be >= registration.min_inliers";
    });
    return t;
  }();
  return *table;
}

bool RgbdSourceOptions::Check(std::string* why) const {
  return frontend.Check(why) && database.Check(why) && prefetch.Check(why) &&
         Table().Check(*this, why);
}

RgbdFrameSource::RgbdFrameSource(const Dataset& dataset, const RgbdSourceOptions& options,
                                 int first_prepared)
    : dataset_(dataset),
      options_(options),
      processor_(dataset.rig(), options.frontend),
      database_(options.database),
      prefetcher_(dataset, processor_, options.prefetch, first_prepared) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  if (dataset.rig().colour_readout_s != 0.0) {
    std::vector<double> timestamps;
    for (int i = 0; i < dataset.size(); ++i) timestamps.push_back(dataset.info(i).timestamp);
    velocities_ =
        std::make_unique<FrameVelocities>(std::move(timestamps), options.velocity_max_step_s);
  }
}

RgbdFrameSource::~RgbdFrameSource() = default;

const ProcessedFrame& RgbdFrameSource::Processed(int frame) {
  CHECK(!finished_ && !handed_over_)
      << "frame " << frame << " asked for after Finish or TakeBaseFrame";
  auto it = processed_.find(frame);
  if (it != processed_.end()) return it->second;
  ProcessedFrame processed = Fetch(frame);
  if (velocities_ && unusable_.count(frame) == 0) Compensate(frame, &processed);
  return processed_.emplace(frame, std::move(processed)).first->second;
}

ProcessedFrame RgbdFrameSource::Fetch(int frame) {
  auto ahead = fetched_ahead_.find(frame);
  if (ahead != fetched_ahead_.end()) {
    ProcessedFrame processed = std::move(ahead->second);
    fetched_ahead_.erase(ahead);
    return processed;
  }
  const auto start = std::chrono::steady_clock::now();
  const std::string name = "frame " + std::to_string(dataset_.info(frame).source_index) + ": ";
  ProcessedFrame processed;
  std::string unusable;
  try {
    PrefetchedFrame fetched = prefetcher_.Take(frame);  // the images are already released
    timings_.fetch_wall_s += SecondsSince(start);
    timings_.load_s += fetched.seconds_load;
    processed = std::move(fetched.processed);
    timings_.extract_s += processed.seconds_extract;
    timings_.lift_s += processed.seconds_lift;
    const FrameInfo& info = dataset_.info(frame);
    const int needed = options_.frontend.registration.min_inliers;
    if (!fetched.has_valid_depth) {
      unusable = name + "range image " + info.depth_path +
                 " has no valid measurement (all zero, invalid or out of range)";
    } else if (processed.features.size() < needed) {
      unusable = name + "too little texture: " + std::to_string(processed.features.size()) +
                 " of " + std::to_string(processed.keypoints_detected) +
                 " keypoints lifted through the range image, registration needs " +
                 std::to_string(needed) + " (" + info.colour_path + ")";
    }
  } catch (const DataError& e) {
    // Load's messages already name the frame and the file.
    timings_.fetch_wall_s += SecondsSince(start);
    unusable = e.what();
  }
  if (!unusable.empty()) {
    processed = ProcessedFrame();  // no features: it can neither register nor be matched
    unusable_[frame] = unusable;
  }
  processed.info = dataset_.info(frame);
  return processed;
}

void RgbdFrameSource::Compensate(int frame, ProcessedFrame* processed) {
  // The frame's own step registrations need it as the front end made it: held aside while
  // its neighbours are fetched and registered.
  auto own = fetched_ahead_.emplace(frame, std::move(*processed)).first;
  const std::optional<CameraVelocity> velocity =
      velocities_->Of(frame, [this](int later) { return RegisterStep(later); });
  *processed = std::move(own->second);
  fetched_ahead_.erase(own);
  if (!velocity) return;
  const Rig& rig = dataset_.rig();
  for (size_t i = 0; i < processed->points.size(); ++i) {
    processed->points[i] = CompensateRollingShutter(
        processed->points[i], processed->features.pixels[i].y(), *velocity, rig);
  }
}

std::optional<Eigen::Isometry3d> RgbdFrameSource::RegisterStep(int later) {
  // Each frame of the step as it is held (compensated already or not: the step's motion is
  // the same to first order), else fetched and kept for when it is asked for itself.
  auto held = [this](int frame) -> const ProcessedFrame& {
    const auto done = processed_.find(frame);
    if (done != processed_.end()) return done->second;
    auto ahead = fetched_ahead_.find(frame);
    if (ahead == fetched_ahead_.end()) ahead = fetched_ahead_.emplace(frame, Fetch(frame)).first;
    return ahead->second;
  };
  const ProcessedFrame& a = held(later - 1);
  return StepMotion(a, held(later), options_.frontend, &timings_.match_s, &timings_.ransac_s);
}

std::string RgbdFrameSource::UnusableReason(int frame) const {
  const auto it = unusable_.find(frame);
  return it == unusable_.end() ? std::string() : it->second;
}

CandidateFrame RgbdFrameSource::Unusable(int frame) const {
  CandidateFrame candidate;
  candidate.frame = frame;
  candidate.timestamp = timestamp(frame);
  candidate.reason = UnusableReason(frame);
  return candidate;
}

std::vector<FrameRegistration> RgbdFrameSource::Register(const std::vector<int>& bases, int frame) {
  // The frames are looked up (processed if need be) here, then the registrations not cached
  // yet run on registration_threads threads: each is a function of the two processed frames
  // and the options alone (RANSAC is seeded per registration), so the thread count changes
  // the time only. Cache and timings are updated in the bases' order afterwards.
  const ProcessedFrame& b = Processed(frame);
  std::vector<FrameRegistration> out(bases.size());
  std::vector<const ProcessedFrame*> base_frames(bases.size(), nullptr);
  std::vector<size_t> todo;
  for (size_t i = 0; i < bases.size(); ++i) {
    const auto cached = registrations_.find({bases[i], frame});
    if (cached != registrations_.end()) {
      out[i] = cached->second;
    } else {
      base_frames[i] = &Processed(bases[i]);
      todo.push_back(i);
    }
  }
  const auto start = std::chrono::steady_clock::now();
  ParallelFor(todo.size(), options_.registration_threads, [&](size_t t) {
    const size_t i = todo[t];
    out[i] = RegisterFrames(*base_frames[i], b, options_.frontend.matching,
                            options_.frontend.registration);
  });
  const double wall = SecondsSince(start);
  double summed = 0.0;
  for (size_t i : todo) {
    timings_.match_s += out[i].seconds_match;
    timings_.ransac_s += out[i].seconds_ransac;
    summed += out[i].seconds_match + out[i].seconds_ransac;
    registrations_.emplace(std::make_pair(bases[i], frame), out[i]);
  }
  timings_.parallel_overlap_s += std::max(0.0, summed - wall);
  return out;
}

CandidateFrame RgbdFrameSource::PrepareFirst(int frame) {
  // The first frame has no base: all of its (capped) lifted keypoints become features. It
  // defines the map, so an unusable one ends the run rather than being skipped.
  Processed(frame);
  const std::string unusable = UnusableReason(frame);
  if (!unusable.empty()) {
    throw DataError("the first frame cannot start the map: " + unusable +
                    " (choose a later first frame with --first)");
  }
  return Build(frame, {});
}

CandidateFrame RgbdFrameSource::Prepare(int frame) {
  const ProcessedFrame& processed = Processed(frame);
  if (unusable_.count(frame) > 0) return Unusable(frame);
  const auto start = std::chrono::steady_clock::now();
  std::vector<int> bases;
  for (const auto& [base, votes] :
       database_.RankFrames(processed.features.descriptors, options_.max_base_candidates)) {
    bases.push_back(base);
  }
  timings_.match_s += SecondsSince(start);
  if (last_base_ >= 0 && std::find(bases.begin(), bases.end(), last_base_) == bases.end()) {
    bases.push_back(last_base_);
  }
  return Build(frame, bases);
}

CandidateFrame RgbdFrameSource::PrepareAgainst(int frame, int base_frame) {
  Processed(frame);
  if (unusable_.count(frame) > 0) return Unusable(frame);
  return Build(frame, {base_frame});
}

CandidateFrame RgbdFrameSource::Build(int frame, const std::vector<int>& bases) {
  const ProcessedFrame& processed = Processed(frame);
  CandidateFrame candidate;
  candidate.frame = frame;
  candidate.timestamp = timestamp(frame);
  const int rows = processed.features.size();
  std::vector<int64_t> row_ids(rows, -1);

  // Register against every base candidate; the one with most inliers is the base frame.
  std::vector<std::pair<int, FrameRegistration>> registered;
  std::string refusal = bases.empty() ? "" : "no base frame to register against";
  std::vector<FrameRegistration> registrations = Register(bases, frame);
  for (size_t i = 0; i < bases.size(); ++i) {
    if (registrations[i].result.success) {
      registered.emplace_back(bases[i], std::move(registrations[i]));
    } else {
      refusal = "base frame " + std::to_string(dataset_.info(bases[i]).source_index) + ": " +
                registrations[i].result.reason;
    }
  }
  std::stable_sort(registered.begin(), registered.end(), [](const auto& x, const auto& y) {
    return x.second.result.inliers.size() > y.second.result.inliers.size();
  });
  if (bases.empty()) {
    candidate.registered = true;  // the first frame: the origin
  } else if (registered.empty()) {
    candidate.reason = refusal;
    return candidate;
  } else {
    candidate.registered = true;
    candidate.base_frame = registered[0].first;
    candidate.T_base_c = registered[0].second.result.T_a_b;
  }

  // Observations of known features through the inlier matches, best registration first;
  // a keypoint's siblings take its id and add no observation of their own.
  const std::vector<int> group = SiblingGroups(processed.features);
  auto assign = [&group, &row_ids](int row, int64_t id) {
    for (int r = group[row]; r < static_cast<int>(group.size()) && group[r] == group[row]; ++r) {
      row_ids[r] = id;
    }
  };
  std::vector<int64_t> used;
  for (size_t r = 0; r < registered.size(); ++r) {
    const auto& [base, registration] = registered[r];
    if (r > 0 &&
        static_cast<int>(registration.result.inliers.size()) < options_.min_inliers_secondary) {
      continue;
    }
    const std::vector<int64_t>& base_ids = feature_ids_.at(base);
    for (int inlier : registration.result.inliers) {
      const DescriptorMatch& match = registration.matches[inlier];
      const int64_t id = base_ids[match.train];
      if (id < 0 || row_ids[match.query] >= 0) continue;
      if (std::find(used.begin(), used.end(), id) != used.end()) continue;
      assign(match.query, id);
      used.push_back(id);
      candidate.observations.push_back(ObservationOf(processed.points[match.query], id));
    }
  }
  candidate.common_features = static_cast<int>(candidate.observations.size());

  // The remaining lifted keypoints, strongest first, become new features if the frame enters.
  int64_t next = next_feature_id_;
  for (int row = 0; row < rows && next - next_feature_id_ < options_.max_new_features_per_frame;
       ++row) {
    if (row_ids[row] >= 0) continue;
    assign(row, next);
    candidate.observations.push_back(ObservationOf(processed.points[row], next));
    ++next;
  }
  pending_[frame] = std::move(row_ids);
  return candidate;
}

void RgbdFrameSource::Commit(const CandidateFrame& candidate) {
  auto it = pending_.find(candidate.frame);
  CHECK(it != pending_.end()) << "frame " << candidate.frame << " committed without Prepare";
  int64_t max_id = next_feature_id_ - 1;
  for (int64_t id : it->second) max_id = std::max(max_id, id);
  // New ids were handed out from next_feature_id_ when the frame was prepared; preparing
  // another frame in between is fine, committing another in between is not.
  for (const FeatureObservation& obs : candidate.observations) {
    CHECK(obs.feature_id < next_feature_id_ || obs.feature_id <= max_id);
  }
  next_feature_id_ = max_id + 1;
  feature_ids_[candidate.frame] = std::move(it->second);
  pending_.erase(it);
  const auto database_start = std::chrono::steady_clock::now();
  database_.Add(candidate.frame, Processed(candidate.frame).features.descriptors);
  timings_.database_s += SecondsSince(database_start);
  last_base_ = candidate.frame;
  // Frames up to this one are prepared again only for recovery, which may redo the work.
  for (auto it = registrations_.begin(); it != registrations_.end();) {
    it = it->first.second <= candidate.frame ? registrations_.erase(it) : std::next(it);
  }
}

void RgbdFrameSource::AddBaseFrame(int frame, ProcessedFrame processed,
                                   std::vector<int64_t> feature_ids) {
  CHECK(!finished_ && !handed_over_ && pending_.empty() && registrations_.empty())
      << "base frame " << frame << " added after frames were prepared";
  CHECK_EQ(static_cast<int>(feature_ids.size()), processed.features.size());
  CHECK(processed_.count(frame) == 0) << "frame " << frame << " is there already";
  for (int64_t id : feature_ids) next_feature_id_ = std::max(next_feature_id_, id + 1);
  if (processed.features.size() > 0) database_.Add(frame, processed.features.descriptors);
  processed_.emplace(frame, std::move(processed));
  feature_ids_.emplace(frame, std::move(feature_ids));
  last_base_ = frame;
}

void RgbdFrameSource::Finish() {
  finished_ = true;
  processed_.clear();
  fetched_ahead_.clear();
  pending_.clear();
  registrations_.clear();
  feature_ids_.clear();
  database_.Clear();
}

std::pair<ProcessedFrame, std::vector<int64_t>> RgbdFrameSource::TakeBaseFrame(int frame) {
  CHECK(!finished_) << "base frame " << frame << " taken after Finish";
  const auto ids = feature_ids_.find(frame);
  const auto processed = processed_.find(frame);
  CHECK(ids != feature_ids_.end() && processed != processed_.end())
      << "frame " << frame << " is no base frame the source holds";
  std::pair<ProcessedFrame, std::vector<int64_t>> taken(std::move(processed->second),
                                                        std::move(ids->second));
  processed_.erase(processed);
  feature_ids_.erase(ids);
  // Registrations against it would need its frame: none may follow.
  handed_over_ = true;
  return taken;
}

void RgbdFrameSource::Release(int frame) {
  if (feature_ids_.count(frame) > 0) return;  // a base frame
  processed_.erase(frame);
  fetched_ahead_.erase(frame);
  pending_.erase(frame);
  for (auto it = registrations_.begin(); it != registrations_.end();) {
    it = it->first.second == frame ? registrations_.erase(it) : std::next(it);
  }
}

}  // namespace ieslam
