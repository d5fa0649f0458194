// Which frames enter the filter: the paper's look-ahead information-gain selection
// (Algorithm 1, "look ahead and search backwards") and the baselines it is compared with,
// behind one interface.
//
//  info           fill a buffer of up to `buffer_size` frames that register against the base
//                 frames; add the one whose addition maximises log det I (equal-dimension rule
//                 for new features); drop the frames before it; restart after it. When even
//                 the best candidate tells little about the map, add the whole buffer.
//  all            the standard EIF: every frame that registers.
//  interval       every `interval`-th frame.
//  deadreckoning  no filter: consecutive registrations chained (the paper's Fig. 9c).
//
// Recovery (the paper's answer to a kidnap): when no frame of a new buffer registers, the
// dropped frames since the last base frame are tried, most recent first; one that registers
// is added, and the new frame is tried again against the grown base database.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "backend/information_filter.h"
#include "backend/observation_gate.h"
#include "core/frame_source.h"
#include "core/option_table.h"

namespace ieslam {

enum class SelectorKind { kInfo, kAll, kInterval, kDeadReckoning };

// "info", "all", "interval", "deadreckoning"; false for anything else.
bool ParseSelectorKind(const std::string& name, SelectorKind* kind);
std::string SelectorKindName(SelectorKind kind);

struct SelectorOptions {
  SelectorKind kind = SelectorKind::kInfo;
  int buffer_size = 3;  // the paper's: the next frame plus two look-ahead frames
  int interval = 5;
  // A frame sharing fewer features with the base database ends the buffer: it is about the
  // least a 3-D registration needs.
  int min_common_features = 10;
  // In nats, on the best candidate's map term (GainTerms::map): below it even the best
  // frame of the buffer tells little about the map already built, and all of the buffer's
  // frames are added (the paper's threshold rule; the default: docs/selection.md).
  double map_gain_threshold = 12.0;
  int max_recovery_frames = 60;  // dropped frames tried when a buffer cannot start
  // The view change, in degrees, a frame needs from the previous candidate (or the last base
  // frame) to become a candidate: the larger of its rotation angle and its parallax angle
  // atan(translation / median range of its observations), through its registration to the
  // last base frame. At 30 Hz consecutive frames see almost the same thing and a buffer of
  // them would be scored on noise (docs/selection.md); 0 makes every frame a candidate.
  double min_view_change_deg = 2.0;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<SelectorOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

// One decision of the selector, for reports and the paper's Figs. 7 and 12.
struct SelectionDecision {
  std::vector<int> candidates;
  std::vector<double> gains;      // GainTerms::total() (nats) per candidate; -inf: not scorable
  std::vector<double> map_gains;  // the map term per candidate
  std::vector<int> added;         // frames added to the filter by this decision
  int scored_features = -1;       // known features all candidates were scored on (-1: own)
  std::string reason;  // "best_gain" | "threshold" | "recovery" | "all" | "interval" | ...
};

// Where each frame ended up.
struct FramePlacement {
  int frame = -1;
  bool selected = false;
  bool placed = false;  // selected, or registered to a base frame
  int base_frame = -1;  // for a non-selected frame
  Eigen::Isometry3d T_base_c = Eigen::Isometry3d::Identity();
  std::string skip_reason;  // when !placed
};

struct SelectionResult {
  std::vector<int> selected;  // in the order added
  // The observations each selected frame entered the filter with (for bundle adjustment).
  std::map<int, std::vector<FeatureObservation>> observations;
  // Each selected frame's observations as registered (with their stated Q), where the
  // filter's gate took them otherwise: refused some, or scaled their Q. The batch
  // refinement may weigh these instead (BundleAdjustmentOptions::refine_registered).
  std::map<int, std::vector<FeatureObservation>> registered;
  std::vector<SelectionDecision> decisions;
  std::vector<FramePlacement> frames;  // one per frame of the source
  // Dead reckoning only: the chained pose of every frame (no filter).
  std::vector<Eigen::Isometry3d> chained_T_w_c;
  // Stopped early by the caller's stop request: frames from `frames_processed` on were not
  // looked at.
  bool interrupted = false;
  int frames_processed = 0;
  double seconds_selection = 0.0;  // preparing candidates and scoring them
  double seconds_filter = 0.0;     // adding to the filter (update + recovery)
  // Wall seconds per frame over each quarter of the frames, in processing order (fewer
  // entries when interrupted): whether a frame costs more as the map grows.
  std::vector<double> seconds_per_frame_by_quarter;
  // What the filter's observation gate kept out of the frames added (or refused).
  GateStatistics gate;
  // What the gate's test at the final estimate took back out of the filter (a finished
  // run's, not an interrupted one's). `observations` keeps what the filter took in.
  WithdrawalStatistics withdrawal;
};

// Where a selection goes on from (mapping continued from a saved map): the filter already
// holds the poses of `selected`, which are the source's frames 0 .. selected.size() - 1 in
// the order they entered the filter, and the source holds them as base frames. The run looks
// at the frames after them; the result lists them as selected, with `observations`.
struct SelectionResume {
  std::vector<int> selected;
  std::map<int, std::vector<FeatureObservation>> observations;
};

class KeyframeSelector {
 public:
  explicit KeyframeSelector(const SelectorOptions& options);

  // Runs over every frame of `source`, adding the selected ones to `filter` (unused by
  // dead reckoning). `progress`, if set, is called with (frames done, frames selected).
  // `stop`, if set, is polled between decisions; when it returns true the run ends there
  // (result.interrupted), with everything decided so far intact. `on_decision`, if set, sees
  // each decision as it is made (not for dead reckoning, which decides nothing). With
  // `resume`, the run goes on from the poses the filter holds (see SelectionResume; not for
  // dead reckoning: ConfigError).
  SelectionResult Run(FrameSource* source, InformationFilter* filter,
                      const std::function<void(int, int)>& progress = nullptr,
                      const std::function<bool()>& stop = nullptr,
                      const std::function<void(const SelectionDecision&)>& on_decision = nullptr,
                      const SelectionResume* resume = nullptr) const;

  // The pose of every placed frame: the filter's estimate for selected frames, the base
  // frame's estimate composed with the registration for the others (dead reckoning: the
  // chain). Frames that were not placed are absent (nullopt).
  static std::vector<std::optional<Eigen::Isometry3d>> FramePoses(const SelectionResult& result,
                                                                  const InformationFilter& filter);

 private:
  SelectionResult RunFrames(FrameSource* source, InformationFilter* filter,
                            const std::function<void(int, int)>& progress,
                            const std::function<bool()>& stop,
                            const std::function<void(const SelectionDecision&)>& on_decision,
                            const SelectionResume* resume) const;

  SelectorOptions options_;
};

}  // namespace ieslam
