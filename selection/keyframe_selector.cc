#include "selection/keyframe_selector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>

#include <glog/logging.h>

#include "backend/observation_gate.h"
#include "core/error.h"
#include "core/pose.h"
#include "core/stopwatch.h"

namespace ieslam {
namespace {

using Clock = std::chrono::steady_clock;

// The larger of the rotation angle of `T` and its parallax angle atan(|t| / median range of
// the observations), in degrees.
double ViewChangeDeg(const Eigen::Isometry3d& T,
                     const std::vector<FeatureObservation>& observations) {
  const double rotation = Eigen::AngleAxisd(T.linear()).angle();
  std::vector<double> ranges;
  for (const FeatureObservation& obs : observations) ranges.push_back(obs.z(2));
  if (ranges.empty()) return rotation * 180.0 / M_PI;
  std::nth_element(ranges.begin(), ranges.begin() + ranges.size() / 2, ranges.end());
  const double parallax = std::atan2(T.translation().norm(), ranges[ranges.size() / 2]);
  return std::max(rotation, parallax) * 180.0 / M_PI;
}

// A decision that adds one frame without scoring a buffer.
SelectionDecision Added(int frame, const std::string& reason) {
  SelectionDecision decision;
  decision.candidates = {frame};
  decision.added = {frame};
  decision.reason = reason;
  return decision;
}

// Wall time per frame over each quarter of a run's frames, from its progress reports
// (frames done so far, never decreasing).
class QuarterClock {
 public:
  explicit QuarterClock(int frames) : frames_(frames), start_(Clock::now()) {}

  void Reach(int done) {
    while (seconds_.size() < 4 &&
           int64_t{done} * 4 >= static_cast<int64_t>(seconds_.size() + 1) * frames_) {
      Close(done);
    }
  }

  // The quarters reached, and the one under way at `done` frames when it is not reached.
  std::vector<double> Finish(int done) {
    Reach(done);
    if (seconds_.size() < 4 && done > done_) Close(done);
    return seconds_;
  }

 private:
  // Ends the current quarter at `done` frames; a report that crosses several quarters at
  // once gives each the same cost per frame.
  void Close(int done) {
    const auto now = Clock::now();
    if (done > done_) {
      seconds_.push_back(std::chrono::duration<double>(now - start_).count() / (done - done_));
    } else {
      seconds_.push_back(seconds_.empty() ? 0.0 : seconds_.back());
    }
    start_ = now;
    done_ = std::max(done_, done);
  }

  const int frames_;
  Clock::time_point start_;
  int done_ = 0;
  std::vector<double> seconds_;
};

// The selector's working state for one run.
class Run {
 public:
  Run(const SelectorOptions& options, FrameSource* source, InformationFilter* filter,
      SelectionResult* result)
      : options_(options), source_(source), filter_(filter), result_(result) {}

  // World pose of a registered candidate through its base frame's current estimate.
  Vector6d InitialPose(const CandidateFrame& c) const {
    return IsometryToPose(PoseToIsometry(filter_->pose(c.base_frame)) * c.T_base_c);
  }

  // Adds the candidate to the filter and commits it; false (frame marked skipped) when the
  // filter refuses it.
  bool Add(const CandidateFrame& c) {
    const auto start = Clock::now();
    std::vector<FeatureObservation> observations = c.observations;
    bool gated_otherwise = false;  // the gate refused some or scaled their Q
    Vector6d T_w_c = InitialPose(c);
    if (filter_->options().gate_chi2 > 0.0) {
      std::vector<int64_t> known;
      for (const FeatureObservation& obs : observations) known.push_back(obs.feature_id);
      GatedObservations gated = GateObservations(
          *filter_, T_w_c, observations, filter_->JointFeatureCovariance(known), /*joint=*/true);
      result_->gate.Add(gated.stats);
      gated_otherwise = gated.stats.rejected > 0 || gated.noise_scale != 1.0;
      observations = std::move(gated.observations);
      if (gated.pose_fitted) T_w_c = gated.T_w_c;
    }
    try {
      filter_->AddPose(c.frame, T_w_c, observations);
    } catch (const DataError& e) {
      result_->seconds_filter += SecondsSince(start);
      Place(c, false);
      result_->frames[c.frame].skip_reason = e.what();
      return false;
    }
    result_->seconds_filter += SecondsSince(start);
    Commit(c);
    result_->selected.push_back(c.frame);
    result_->observations[c.frame] = std::move(observations);
    if (gated_otherwise) result_->registered[c.frame] = c.observations;
    FramePlacement& placement = result_->frames[c.frame];
    placement.selected = placement.placed = true;
    placement.skip_reason.clear();
    // The dropped frames before the new base frame are behind every later recovery (which
    // looks at frames after the last base frame only); interval placement revisits them.
    if (options_.kind != SelectorKind::kInterval) {
      for (int d = last_base_ + 1; d < c.frame; ++d) {
        if (!result_->frames[d].selected) source_->Release(d);
      }
    }
    last_base_ = c.frame;
    return true;
  }

  // Records a registered, non-selected frame's registration to its base frame.
  void Place(const CandidateFrame& c, bool placed) {
    FramePlacement& placement = result_->frames[c.frame];
    if (placement.selected) return;
    placement.placed = placed && c.registered;
    placement.base_frame = c.base_frame;
    placement.T_base_c = c.T_base_c;
    placement.skip_reason = c.registered ? "" : c.reason;
  }

  // Committing counts as selection time, as preparing does: the front end's share of it
  // (adding the frame to the base frame database) is taken out of the report's figure.
  void Commit(const CandidateFrame& c) {
    const auto start = Clock::now();
    source_->Commit(c);
    result_->seconds_selection += SecondsSince(start);
  }

  CandidateFrame Prepare(int frame) {
    const auto start = Clock::now();
    CandidateFrame c = source_->Prepare(frame);
    result_->seconds_selection += SecondsSince(start);
    Place(c, true);
    return c;
  }

  bool Usable(const CandidateFrame& c) const {
    return c.registered && c.common_features >= options_.min_common_features;
  }

  void AddFirst(int frame) {
    // Preparing counts as selection time for every frame, the first too: the front end's
    // share of it (loading, matching, RANSAC) is taken out of the report's figure as a
    // whole.
    const auto prepare_start = Clock::now();
    const CandidateFrame c = source_->PrepareFirst(frame);
    result_->seconds_selection += SecondsSince(prepare_start);
    const auto start = Clock::now();
    filter_->AddFirstPose(frame, IsometryToPose(c.T_base_c), c.observations);
    result_->seconds_filter += SecondsSince(start);
    Commit(c);
    result_->selected.push_back(frame);
    result_->observations[frame] = c.observations;
    result_->frames[frame].selected = result_->frames[frame].placed = true;
    Record(Added(frame, "first"));
    last_base_ = frame;
  }

  // The frames the filter holds already, as if selected by this run.
  void Resume(const SelectionResume& resume) {
    CHECK_EQ(static_cast<int>(resume.selected.size()), filter_->num_poses());
    for (const int frame : resume.selected) {
      CHECK(frame >= 0 && frame < static_cast<int>(resume.selected.size()) &&
            filter_->HasPose(frame))
          << "resumed frame " << frame;
      result_->selected.push_back(frame);
      const auto it = resume.observations.find(frame);
      if (it != resume.observations.end()) result_->observations[frame] = it->second;
      result_->frames[frame].selected = result_->frames[frame].placed = true;
    }
    last_base_ = resume.selected.back();
  }

  // Tries the dropped frames after the last base frame, most recent first, until one is
  // added. True when one was.
  bool Recover(int before) {
    int tried = 0;
    for (int d = before - 1; d > last_base_ && tried < options_.max_recovery_frames; --d, ++tried) {
      if (result_->frames[d].selected) continue;
      const CandidateFrame c = Prepare(d);
      if (Usable(c) && Add(c)) {
        Record(Added(d, "recovery"));
        return true;
      }
    }
    return false;
  }

  // Whether the filter holds the feature, or would take it in with this sighting (a pending
  // one seen often enough): a feature of the map, for the scoring.
  bool OfTheMap(int64_t feature_id) const {
    return filter_->HasFeature(feature_id) ||
           (filter_->IsPending(feature_id) && filter_->Enters(feature_id));
  }

  // Scores a buffer: total gains and map terms of the filter holding every feature from its
  // first sighting (GainTerms: delayed initialisation changes the state, not the choice),
  // with the equal-dimension rule for the features no pose has seen, and equal measurements
  // of the map's features (known ones, and pending ones a candidate would bring in), gated as
  // that filter would gate them: every candidate is scored on its observations of those
  // that all candidates of the buffer observe. Scored on all their observations, candidates
  // nearer the base frames win by counting more matches (at 30 Hz the next frame always
  // would); on the same features, the gain measures what the candidate's viewpoint adds. With
  // too few features in common, each candidate's own are used, as in the paper.
  void Score(const std::vector<CandidateFrame>& buffer, SelectionDecision* decision) {
    const auto start = Clock::now();
    std::vector<std::vector<int64_t>> seen(buffer.size());
    for (size_t k = 0; k < buffer.size(); ++k) {
      for (const FeatureObservation& obs : buffer[k].observations) {
        if (OfTheMap(obs.feature_id)) seen[k].push_back(obs.feature_id);
      }
      std::sort(seen[k].begin(), seen[k].end());
    }
    std::vector<int64_t> common = seen[0];
    for (size_t k = 1; k < buffer.size(); ++k) {
      std::vector<int64_t> both;
      std::set_intersection(common.begin(), common.end(), seen[k].begin(), seen[k].end(),
                            std::back_inserter(both));
      common.swap(both);
    }
    const bool equal_measurements = static_cast<int>(common.size()) >= options_.min_common_features;
    std::vector<std::vector<FeatureObservation>> scored(buffer.size());
    int min_first = std::numeric_limits<int>::max();
    std::vector<int> earlier_frames;  // poses whose sightings the entering features join
    for (size_t k = 0; k < buffer.size(); ++k) {
      for (const FeatureObservation& obs : buffer[k].observations) {
        if (!OfTheMap(obs.feature_id) || !equal_measurements ||
            std::binary_search(common.begin(), common.end(), obs.feature_id)) {
          scored[k].push_back(obs);
        }
      }
      min_first = std::min(min_first, filter_->CountFirstSightings(scored[k]));
      const std::vector<int> frames = filter_->EarlierSightingFrames(scored[k]);
      earlier_frames.insert(earlier_frames.end(), frames.begin(), frames.end());
    }
    std::sort(earlier_frames.begin(), earlier_frames.end());
    earlier_frames.erase(std::unique(earlier_frames.begin(), earlier_frames.end()),
                         earlier_frames.end());
    std::vector<int64_t> all_seen;
    for (const auto& ids : seen) all_seen.insert(all_seen.end(), ids.begin(), ids.end());
    std::sort(all_seen.begin(), all_seen.end());
    all_seen.erase(std::unique(all_seen.begin(), all_seen.end()), all_seen.end());
    const FeatureCovariance covariance =
        filter_->JointFeatureCovariance(equal_measurements ? common : all_seen, earlier_frames);
    for (size_t k = 0; k < buffer.size(); ++k) {
      const CandidateFrame& c = buffer[k];
      Vector6d T_w_c = InitialPose(c);
      if (filter_->options().gate_chi2 > 0.0) {
        // Scored on the observations that pass the single gates, with the stated Q: a
        // candidate is not credited for an outlier, at the price of candidates scored on
        // slightly different common features. The joint test and the Q scaling are left to
        // the frame that enters (a per-candidate scale would reward a noisier frame).
        GatedObservations gated =
            GateObservations(*filter_, T_w_c, scored[k], covariance, /*joint=*/false);
        scored[k] = std::move(gated.observations);
        if (gated.pose_fitted) T_w_c = gated.T_w_c;
      }
      GainTerms terms;
      // -infinity when a feature lies behind the candidate's camera: the registration is
      // wrong, and the candidate not scorable.
      const double gain = filter_->InformationGain(T_w_c, scored[k], min_first, covariance, &terms);
      decision->candidates.push_back(c.frame);
      decision->gains.push_back(std::isfinite(gain) ? terms.total() : gain);
      decision->map_gains.push_back(std::isfinite(gain) ? terms.map : gain);
    }
    decision->scored_features = equal_measurements ? static_cast<int>(common.size()) : -1;
    result_->seconds_selection += SecondsSince(start);
  }

  // Registers a frame against the last base frame only, which places it.
  CandidateFrame PrepareAgainstLastBase(int frame) {
    const auto start = Clock::now();
    const CandidateFrame c = source_->PrepareAgainst(frame, last_base_);
    result_->seconds_selection += SecondsSince(start);
    Place(c, true);
    return c;
  }

  // From frame `next` on.
  void RunInfo(int next) {
    const int n = source_->size();
    while (next < n) {
      if (Stopped(next)) return;
      // Candidates: frames that change the view enough from the previous candidate (from the
      // last base frame, for the first one). Frames that do not register to the last base
      // frame are candidates too: the full preparation may find other base frames.
      std::vector<CandidateFrame> buffer;
      Eigen::Isometry3d T_base_previous = Eigen::Isometry3d::Identity();
      int f = next;
      int refused = -1;
      for (; f < n && static_cast<int>(buffer.size()) < options_.buffer_size; ++f) {
        if (options_.min_view_change_deg > 0.0) {
          const CandidateFrame against = PrepareAgainstLastBase(f);
          if (against.registered) {
            const Eigen::Isometry3d T_previous_f = T_base_previous.inverse() * against.T_base_c;
            if (ViewChangeDeg(T_previous_f, against.observations) < options_.min_view_change_deg) {
              continue;
            }
            T_base_previous = against.T_base_c;
          }
        }
        CandidateFrame c = Prepare(f);
        if (!Usable(c)) {
          refused = f;
          break;
        }
        buffer.push_back(std::move(c));
      }
      if (buffer.empty()) {
        if (refused < 0) break;  // the sequence ended before another candidate
        // Frame `refused` does not register: recover through dropped frames, or skip it.
        if (Recover(refused)) {
          next = last_base_ + 1;
          continue;
        }
        next = refused + 1;
        Progress(next);
        continue;
      }
      SelectionDecision decision;
      Score(buffer, &decision);
      const auto best =
          std::max_element(decision.gains.begin(), decision.gains.end()) - decision.gains.begin();
      const double map_gain = decision.map_gains[best];
      if (!std::isfinite(decision.gains[best])) {
        decision.reason = "unscorable";
        next = buffer.back().frame + 1;
      } else if (map_gain < options_.map_gain_threshold && buffer.size() > 1) {
        decision.reason = "threshold";
        // Each frame is prepared again after the previous one entered: its data
        // association and base frames change with every commit.
        for (size_t k = 0; k < buffer.size(); ++k) {
          const CandidateFrame c = k == 0 ? buffer[0] : Prepare(buffer[k].frame);
          if (Usable(c) && Add(c)) decision.added.push_back(c.frame);
        }
        next = buffer.back().frame + 1;
      } else {
        decision.reason = "best_gain";
        if (Add(buffer[best])) decision.added.push_back(buffer[best].frame);
        next = buffer[best].frame + 1;
      }
      Record(std::move(decision));
      Progress(next);
    }
  }

  // all / interval: every frame (or every interval-th, counted from `origin`) that registers,
  // after the frames the filter holds (those before `origin`, or frame 0).
  void RunEvery(int step, int origin) {
    const int n = source_->size();
    const int first = std::max(origin, 1);
    for (int f = first; f < n; ++f) {
      if (Stopped(f)) return;
      if ((f - origin) % step != 0) continue;
      const CandidateFrame c = Prepare(f);
      if (Usable(c) && Add(c)) {
        Record(Added(f, step == 1 ? "all" : "interval"));
      } else if (Recover(f)) {
        Retry(f);  // a frame that still does not register keeps its reason in `frames`
      }
      Progress(f + 1);
    }
    // Frames between interval frames are placed by registration only.
    if (step > 1) {
      for (int f = first; f < n; ++f) {
        if ((f - origin) % step != 0) Prepare(f);
      }
    }
  }

  void Retry(int f) {
    const CandidateFrame c = Prepare(f);
    if (Usable(c) && Add(c)) Record(Added(f, "recovered"));
  }

  void Record(SelectionDecision decision) {
    result_->decisions.push_back(std::move(decision));
    if (on_decision_) on_decision_(result_->decisions.back());
  }

  void Progress(int done) {
    if (progress_)
      progress_(std::min(done, source_->size()), static_cast<int>(result_->selected.size()));
  }

  // True (and the result marked interrupted) when the caller asked to stop.
  bool Stopped(int next_frame) {
    if (!stop_ || !stop_()) return false;
    result_->interrupted = true;
    result_->frames_processed = next_frame;
    return true;
  }

  std::function<void(int, int)> progress_;
  std::function<bool()> stop_;
  std::function<void(const SelectionDecision&)> on_decision_;
  int last_base_ = 0;

 private:
  const SelectorOptions& options_;
  FrameSource* source_;
  InformationFilter* filter_;
  SelectionResult* result_;
};

}  // namespace

bool ParseSelectorKind(const std::string& name, SelectorKind* kind) {
  if (name == "info")
    *kind = SelectorKind::kInfo;
  else if (name == "all")
    *kind = SelectorKind::kAll;
  else if (name == "interval")
    *kind = SelectorKind::kInterval;
  else if (name == "deadreckoning")
    *kind = SelectorKind::kDeadReckoning;
  else
    return false;
  return true;
}

std::string SelectorKindName(SelectorKind kind) {
  switch (kind) {
    case SelectorKind::kInfo:
      return "info";
    case SelectorKind::kAll:
      return "all";
    case SelectorKind::kInterval:
      return "interval";
    case SelectorKind::kDeadReckoning:
      return "deadreckoning";
  }
  return "?";
}

const OptionTable<SelectorOptions>& SelectorOptions::Table() {
  static const OptionTable<SelectorOptions>* table = [] {
    using O = SelectorOptions;
    auto* t = new OptionTable<O>;
    t->Enum("kind", &O::kind, ParseSelectorKind, SelectorKindName,
            "info|all|interval|deadreckoning", "which frames enter the filter");
    t->Int("buffer", &O::buffer_size, "look-ahead buffer of the info selector").Range(1, 100);
    t->Int("interval", &O::interval, "every N-th frame for the interval selector").Min(1);
    t->Int("min_common_features", &O::min_common_features,
           "features shared with the base frames a candidate needs")
        .Min(3);
    t->Double("map_gain_threshold", &O::map_gain_threshold,
              "nats: below it the whole buffer is added");
    t->Int("max_recovery_frames", &O::max_recovery_frames,
           "dropped frames tried when a buffer cannot start")
        .Min(0);
    t->Double("min_view_change_deg", &O::min_view_change_deg,
              "info selector: view change from one candidate to the next")
        .Min(0.0)
        .Below(90.0);
    return t;
  }();
  return *table;
}

KeyframeSelector::KeyframeSelector(const SelectorOptions& options) : options_(options) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
}

SelectionResult KeyframeSelector::Run(
    FrameSource* source, InformationFilter* filter, const std::function<void(int, int)>& progress,
    const std::function<bool()>& stop,
    const std::function<void(const SelectionDecision&)>& on_decision,
    const SelectionResume* resume) const {
  if (resume != nullptr && options_.kind == SelectorKind::kDeadReckoning) {
    throw ConfigError("mapping on from a saved map needs a filter: not with deadreckoning");
  }
  // The quarters are of the frames this run looks at.
  const int first = resume != nullptr ? static_cast<int>(resume->selected.size()) : 0;
  QuarterClock quarters(source->size() - first);
  const std::function<void(int, int)> timed = [&](int done, int selected) {
    quarters.Reach(done - first);
    if (progress) progress(done, selected);
  };
  SelectionResult result = RunFrames(source, filter, timed, stop, on_decision, resume);
  result.seconds_per_frame_by_quarter =
      quarters.Finish(std::max(0, result.frames_processed - first));
  // After the quarters: it is no frame's cost.
  if (options_.kind != SelectorKind::kDeadReckoning && !result.interrupted) {
    result.withdrawal = filter->WithdrawInconsistent();
    result.seconds_filter += result.withdrawal.seconds;
  }
  return result;
}

SelectionResult KeyframeSelector::RunFrames(
    FrameSource* source, InformationFilter* filter, const std::function<void(int, int)>& progress,
    const std::function<bool()>& stop,
    const std::function<void(const SelectionDecision&)>& on_decision,
    const SelectionResume* resume) const {
  SelectionResult result;
  const int n = source->size();
  result.frames_processed = n;
  if (n == 0) return result;
  result.frames.resize(n);
  for (int f = 0; f < n; ++f) result.frames[f].frame = f;

  if (options_.kind == SelectorKind::kDeadReckoning) {
    // Each frame registered to the one before it; a frame that does not register is
    // skipped and the next is registered to the last placed one.
    result.chained_T_w_c.assign(n, Eigen::Isometry3d::Identity());
    const auto first_start = Clock::now();
    const CandidateFrame first = source->PrepareFirst(0);
    source->Commit(first);
    result.seconds_selection += SecondsSince(first_start);
    result.chained_T_w_c[0] = first.T_base_c;
    result.frames[0].selected = result.frames[0].placed = true;
    result.selected.push_back(0);
    int last = 0;
    for (int f = 1; f < n; ++f) {
      if (stop && stop()) {
        result.interrupted = true;
        result.frames_processed = f;
        return result;
      }
      const auto start = Clock::now();
      const CandidateFrame c = source->PrepareAgainst(f, last);
      FramePlacement& placement = result.frames[f];
      if (!c.registered) {
        result.seconds_selection += SecondsSince(start);
        placement.skip_reason = c.reason;
        continue;
      }
      source->Commit(c);
      result.seconds_selection += SecondsSince(start);
      result.chained_T_w_c[f] = result.chained_T_w_c[last] * c.T_base_c;
      placement.selected = placement.placed = true;
      placement.base_frame = last;
      placement.T_base_c = c.T_base_c;
      result.selected.push_back(f);
      last = f;
      if (progress) progress(f + 1, static_cast<int>(result.selected.size()));
    }
    return result;
  }

  CHECK(filter != nullptr);
  class Run run(options_, source, filter, &result);
  run.progress_ = progress;
  run.stop_ = stop;
  run.on_decision_ = on_decision;
  // The run goes on after the frames the filter holds: frame 0, or the resumed ones.
  const int origin = resume != nullptr ? static_cast<int>(resume->selected.size()) : 0;
  if (resume != nullptr) {
    run.Resume(*resume);
  } else {
    run.AddFirst(0);
  }
  switch (options_.kind) {
    case SelectorKind::kInfo:
      run.RunInfo(std::max(origin, 1));
      break;
    case SelectorKind::kAll:
      run.RunEvery(1, origin);
      break;
    case SelectorKind::kInterval:
      run.RunEvery(options_.interval, origin);
      break;
    case SelectorKind::kDeadReckoning:
      break;
  }
  return result;
}

std::vector<std::optional<Eigen::Isometry3d>> KeyframeSelector::FramePoses(
    const SelectionResult& result, const InformationFilter& filter) {
  std::vector<std::optional<Eigen::Isometry3d>> poses(result.frames.size());
  if (!result.chained_T_w_c.empty()) {
    for (const FramePlacement& p : result.frames) {
      if (p.placed) poses[p.frame] = result.chained_T_w_c[p.frame];
    }
    return poses;
  }
  for (const FramePlacement& p : result.frames) {
    if (p.selected && filter.HasPose(p.frame)) {
      poses[p.frame] = PoseToIsometry(filter.pose(p.frame));
    } else if (p.placed && filter.HasPose(p.base_frame)) {
      poses[p.frame] = PoseToIsometry(filter.pose(p.base_frame)) * p.T_base_c;
    }
  }
  return poses;
}

}  // namespace ieslam
