#include "selection/pipeline/continued_dataset.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "core/calibration.h"
#include "core/error.h"
#include "core/pose.h"
#include "selection/pipeline/run_options.h"

namespace ieslam {

ContinuedDataset::ContinuedDataset(const LoadedMap& map, const Dataset& next,
                                   const DatasetOptions& options)
    : Dataset(next.directory(), options), map_(map), format_(next.format()) {
  const std::vector<MapKeyframe>& keyframes = map.map.keyframes;
  if (keyframes.empty()) throw DataError(map.file() + ": the map holds no keyframe");
  CheckMapCalibration(map.map, next.rig(), map.directory);
  rig_ = next.rig();
  total_frames_ = map_frames() + next.total_frames();
  calibration_path_ = next.calibration_path();
  calibration_source_ = next.calibration_source();
  calibration_chosen_by_ = next.calibration_chosen_by();
  warnings_ = next.warnings();

  for (size_t k = 0; k < keyframes.size(); ++k) {
    const MapKeyframe& keyframe = keyframes[k];
    if (k > 0 && keyframe.timestamp < keyframes[k - 1].timestamp) {
      throw DataError(map.file() + ": keyframe " + std::to_string(k) + " (" +
                      std::to_string(keyframe.timestamp) + " s) comes before keyframe " +
                      std::to_string(k - 1) + " in time");
    }
    FrameInfo info;
    info.index = static_cast<int>(k);
    info.source_index = keyframe.origin.source_index;
    info.timestamp = keyframe.timestamp;
    if (keyframe.has_ground_truth) info.T_w_c_gt = PoseToIsometry(keyframe.ground_truth);
    frames_.push_back(info);
  }
  FindMapImages();
  const double last_map_s = keyframes.back().timestamp;
  if (next.size() > 0 && next.info(0).timestamp <= last_map_s) {
    timestamp_shift_s_ = last_map_s + 1.0 - next.info(0).timestamp;
    warnings_.push_back("the dataset's first frame (" + std::to_string(next.info(0).timestamp) +
                        " s) is not later than the map's last keyframe (" +
                        std::to_string(last_map_s) + " s): its timestamps are shifted by " +
                        std::to_string(timestamp_shift_s_) + " s in the outputs");
  }
  for (int f = 0; f < next.size(); ++f) {
    FrameInfo info = next.info(f);
    info.index = map_frames() + f;
    info.timestamp += timestamp_shift_s_;
    frames_.push_back(std::move(info));
  }
}

void ContinuedDataset::FindMapImages() {
  const SavedMap& map = map_.map;
  map_images_.assign(map.keyframes.size(), false);
  std::map<std::string, std::vector<int>> by_dataset;  // origin -> its keyframes
  for (int k = 0; k < map_frames(); ++k) by_dataset[map.keyframes[k].origin.dataset].push_back(k);
  for (const auto& [directory, keyframes] : by_dataset) {
    const auto missing = [&, dir = directory](const std::string& why) {
      map_images_missing_ += (map_images_missing_.empty() ? "" : "; ") + dir + ": " + why;
    };
    std::unique_ptr<Dataset> origin;
    try {
      origin = OpenDataset(directory, MapDatasetOptions(map.options, map_.file()));
    } catch (const std::runtime_error& e) {
      missing(std::string("cannot be opened: ") + e.what());
      continue;
    }
    if (FormatCalibration(origin->rig()) != map.calibration) {
      missing("another calibration than the map's");
      continue;
    }
    int absent = 0;
    for (const int k : keyframes) {
      const FrameOrigin& o = map.keyframes[k].origin;
      // A frame read again from the same files has the same timestamp.
      if (o.source_index < 0 || o.source_index >= origin->size() ||
          std::abs(origin->info(o.source_index).timestamp - o.timestamp) > 1e-6) {
        ++absent;
        continue;
      }
      frames_[k].colour_path = origin->info(o.source_index).colour_path;
      frames_[k].depth_path = origin->info(o.source_index).depth_path;
      map_images_[k] = true;
    }
    if (absent > 0) {
      missing("no frame at the timestamps of " + std::to_string(absent) + " of its " +
              std::to_string(keyframes.size()) + " keyframes");
    }
  }
}

int ContinuedDataset::map_frames_without_images() const {
  return static_cast<int>(std::count(map_images_.begin(), map_images_.end(), false));
}

FrameOrigin ContinuedDataset::origin(int frame) const {
  if (frame < map_frames()) return map_.map.keyframes[frame].origin;
  return OriginIn(*this, frame, timestamp_shift_s_);
}

void ContinuedDataset::AddBaseFrames(RgbdFrameSource* source) const {
  for (int k = 0; k < map_frames(); ++k) {
    const MapBaseFrame& base = map_.map.base_frames[k];
    source->AddBaseFrame(k, ProcessedBaseFrame(base, info(k)), base.feature_ids);
  }
  int64_t next_id = 0;
  for (const MapFeature& f : map_.map.features) next_id = std::max(next_id, f.id + 1);
  for (const PendingFeature& p : map_.map.filter.pending) next_id = std::max(next_id, p.id + 1);
  source->ReserveFeatureIdsBelow(next_id);
}

PipelineResume ContinuedDataset::Resume() const {
  PipelineResume resume;
  resume.filter = map_.map.filter;
  std::unordered_map<int, int> renumbered;
  for (int k = 0; k < map_frames(); ++k) renumbered.emplace(map_.map.keyframes[k].frame, k);
  // The map's consistency check holds the filter's poses to the keyframes, one for one.
  for (auto& [frame, offset] : resume.filter.pose_offsets) frame = renumbered.at(frame);
  // The pending features' sightings name keyframes too (the filter's Restore checks them).
  for (PendingFeature& p : resume.filter.pending) {
    for (FeatureSighting& sighting : p.sightings) {
      const auto it = renumbered.find(sighting.frame_id);
      if (it != renumbered.end()) sighting.frame_id = it->second;
    }
  }
  for (int k = 0; k < map_frames(); ++k) {
    resume.selection.selected.push_back(k);
    resume.selection.observations[k] = map_.map.keyframes[k].observations;
  }
  return resume;
}

}  // namespace ieslam
