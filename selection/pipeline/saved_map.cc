#include "selection/pipeline/saved_map.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <unordered_set>

#include <glog/logging.h>

#include "core/error.h"
#include "core/file_util.h"
#include "core/section_file.h"
#include "core/stopwatch.h"
#include "core/version.h"

namespace ieslam {
namespace {

constexpr char kMapMagic[] = "IESLAMAP";
// Features per marginal recovery: each recovery solves against 3 columns per feature and
// forms their joint covariance, of which only the 3x3 diagonal blocks are kept; the joint
// part grows with the square of the batch, the per-call overhead with the number of calls.
constexpr size_t kFeaturesPerRecovery = 16;
constexpr int kDescriptorBytes = 128;

template <typename Derived>
void WriteMatrix(const Eigen::MatrixBase<Derived>& m, SectionWriter* w) {
  for (int c = 0; c < m.cols(); ++c) {
    for (int r = 0; r < m.rows(); ++r) w->F64(m(r, c));
  }
}

template <typename Derived>
void ReadMatrix(SectionReader* r, Eigen::MatrixBase<Derived>* m) {
  for (int c = 0; c < m->cols(); ++c) {
    for (int row = 0; row < m->rows(); ++row) (*m)(row, c) = r->F64();
  }
}

std::string WriteMeta(const SavedMap& map) {
  SectionWriter w;
  w.String(map.version);
  w.String(map.calibration);
  w.String(map.options);
  w.String(map.dataset);
  return w.Take();
}

std::string WriteKeyframes(const SavedMap& map) {
  SectionWriter w;
  w.U64(map.keyframes.size());
  for (const MapKeyframe& k : map.keyframes) {
    w.I32(k.frame);
    w.String(k.origin.dataset);
    w.I32(k.origin.source_index);
    w.F64(k.origin.timestamp);
    w.F64(k.timestamp);
    WriteMatrix(k.pose, &w);
    WriteMatrix(k.covariance, &w);
    w.U8(k.refined ? 1 : 0);
    WriteMatrix(k.refined_pose, &w);
    w.U8(k.has_ground_truth ? 1 : 0);
    WriteMatrix(k.ground_truth, &w);
    w.U64(k.observations.size());
    for (const FeatureObservation& o : k.observations) {
      w.I64(o.feature_id);
      WriteMatrix(o.z, &w);
      WriteMatrix(o.Q, &w);
    }
  }
  return w.Take();
}

std::string WriteFeatures(const SavedMap& map) {
  SectionWriter w;
  w.U64(map.features.size());
  for (const MapFeature& f : map.features) {
    w.I64(f.id);
    WriteMatrix(f.p_w, &w);
    WriteMatrix(f.covariance, &w);
  }
  return w.Take();
}

// Frame by frame: the section is the largest by far, and is never held whole.
void WriteBaseFrames(const SavedMap& map, SectionSink* sink) {
  SectionWriter count;
  count.U64(map.base_frames.size());
  sink->Append(count.Take());
  for (const MapBaseFrame& b : map.base_frames) {
    const int n = b.features.size();
    CHECK_EQ(static_cast<int>(b.points.size()), n);
    CHECK_EQ(static_cast<int>(b.feature_ids.size()), n);
    CHECK(n == 0 || (b.features.descriptors.type() == CV_8U && b.features.descriptors.rows == n &&
                     b.features.descriptors.cols == kDescriptorBytes &&
                     b.features.descriptors.isContinuous()));
    SectionWriter w;
    w.I32(b.frame);
    w.F64(b.timestamp);
    w.U64(n);
    for (int i = 0; i < n; ++i) {
      WriteMatrix(b.features.pixels[i], &w);
      w.F32(b.features.scales[i]);
      w.Bytes(b.features.colours[i].val, 3);
      const LiftedPoint& p = b.points[i];
      w.U8(p.valid ? 1 : 0);
      WriteMatrix(p.p_c, &w);
      WriteMatrix(p.z, &w);
      WriteMatrix(p.Q, &w);
      WriteMatrix(p.p_c_covariance, &w);
      w.I64(b.feature_ids[i]);
    }
    if (n > 0) w.Bytes(b.features.descriptors.data, static_cast<size_t>(n) * kDescriptorBytes);
    sink->Append(w.Take());
  }
}

// In pieces: the matrix's arrays are the second-largest part of a map.
void WriteFilter(const MapFilterState& f, SectionSink* sink) {
  constexpr size_t kPiece = 1 << 16;
  SectionWriter w;
  const auto flush = [&](bool force) {
    if (force || w.payload().size() >= kPiece) sink->Append(w.Take());
  };
  w.I32(f.dim);
  w.U64(f.column_starts.size());
  for (int v : f.column_starts) {
    w.I32(v);
    flush(false);
  }
  w.U64(f.rows.size());
  for (int v : f.rows) {
    w.I32(v);
    flush(false);
  }
  for (double v : f.values) {
    w.F64(v);
    flush(false);
  }
  WriteMatrix(f.information_vector, &w);
  WriteMatrix(f.state, &w);
  w.U64(f.pose_offsets.size());
  for (const auto& [id, offset] : f.pose_offsets) {
    w.I32(id);
    w.I32(offset);
  }
  w.U64(f.feature_offsets.size());
  for (const auto& [id, offset] : f.feature_offsets) {
    w.I64(id);
    w.I32(offset);
  }
  w.U64(f.pending.size());
  for (const PendingFeature& p : f.pending) {
    w.I64(p.id);
    w.U64(p.sightings.size());
    for (const FeatureSighting& sighting : p.sightings) {
      w.I32(sighting.frame_id);
      WriteMatrix(sighting.observation.z, &w);
      WriteMatrix(sighting.observation.Q, &w);
    }
  }
  flush(true);
}

void ReadMeta(SectionReader* r, SavedMap* map) {
  map->version = r->String();
  map->calibration = r->String();
  map->options = r->String();
  map->dataset = r->String();
}

void ReadKeyframes(SectionReader* r, SavedMap* map) {
  const size_t n = r->Count(4 + 8 + 4 + 8 + 8 + 6 * 8 + 36 * 8 + 1 + 6 * 8 + 1 + 6 * 8 + 8);
  map->keyframes.resize(n);
  for (MapKeyframe& k : map->keyframes) {
    k.frame = r->I32();
    k.origin.dataset = r->String();
    k.origin.source_index = r->I32();
    k.origin.timestamp = r->F64();
    k.timestamp = r->F64();
    ReadMatrix(r, &k.pose);
    ReadMatrix(r, &k.covariance);
    k.refined = r->U8() != 0;
    ReadMatrix(r, &k.refined_pose);
    k.has_ground_truth = r->U8() != 0;
    ReadMatrix(r, &k.ground_truth);
    k.observations.resize(r->Count(8 + 12 * 8));
    for (FeatureObservation& o : k.observations) {
      o.feature_id = r->I64();
      ReadMatrix(r, &o.z);
      ReadMatrix(r, &o.Q);
    }
  }
}

void ReadFeatures(SectionReader* r, SavedMap* map) {
  const size_t n = r->Count(8 + 12 * 8);
  map->features.resize(n);
  for (MapFeature& f : map->features) {
    f.id = r->I64();
    ReadMatrix(r, &f.p_w);
    ReadMatrix(r, &f.covariance);
  }
}

void ReadBaseFrames(SectionReader* r, SavedMap* map) {
  // Per keypoint: pixel, scale, colour, valid, p_c, z, Q, its covariance, id, descriptor.
  constexpr size_t kPointBytes = 16 + 4 + 3 + 1 + 24 + 24 + 72 + 72 + 8 + kDescriptorBytes;
  const size_t frames = r->Count(4 + 8 + 8);
  map->base_frames.resize(frames);
  for (MapBaseFrame& b : map->base_frames) {
    b.frame = r->I32();
    b.timestamp = r->F64();
    const int n = static_cast<int>(r->Count(kPointBytes));
    b.features.pixels.resize(n);
    b.features.scales.resize(n);
    b.features.colours.resize(n);
    b.points.resize(n);
    b.feature_ids.resize(n);
    for (int i = 0; i < n; ++i) {
      ReadMatrix(r, &b.features.pixels[i]);
      b.features.scales[i] = r->F32();
      r->Bytes(b.features.colours[i].val, 3);
      LiftedPoint& p = b.points[i];
      p.valid = r->U8() != 0;
      ReadMatrix(r, &p.p_c);
      ReadMatrix(r, &p.z);
      ReadMatrix(r, &p.Q);
      ReadMatrix(r, &p.p_c_covariance);
      b.feature_ids[i] = r->I64();
    }
    b.features.descriptors = cv::Mat(n, kDescriptorBytes, CV_8U);
    if (n > 0) r->Bytes(b.features.descriptors.data, static_cast<size_t>(n) * kDescriptorBytes);
  }
}

void ReadFilter(SectionReader* r, MapFilterState* f) {
  f->dim = r->I32();
  if (f->dim < 0) r->Fail("a negative state dimension");
  f->column_starts.resize(r->Count(4));
  for (int& v : f->column_starts) v = r->I32();
  const size_t nonzeros = r->Count(4 + 8);
  f->rows.resize(nonzeros);
  for (int& v : f->rows) v = r->I32();
  f->values.resize(nonzeros);
  for (double& v : f->values) v = r->F64();
  if (static_cast<size_t>(f->dim) > r->remaining() / 16) {
    r->Fail("a state dimension of " + std::to_string(f->dim) + " is more than the rest can hold");
  }
  f->information_vector.resize(f->dim);
  ReadMatrix(r, &f->information_vector);
  f->state.resize(f->dim);
  ReadMatrix(r, &f->state);
  f->pose_offsets.resize(r->Count(8));
  for (auto& [id, offset] : f->pose_offsets) {
    id = r->I32();
    offset = r->I32();
  }
  f->feature_offsets.resize(r->Count(12));
  for (auto& [id, offset] : f->feature_offsets) {
    id = r->I64();
    offset = r->I32();
  }
  f->pending.resize(r->Count(8 + 8));
  for (PendingFeature& p : f->pending) {
    p.id = r->I64();
    p.sightings.resize(r->Count(4 + 12 * 8));
    for (FeatureSighting& sighting : p.sightings) {
      sighting.frame_id = r->I32();
      sighting.observation.feature_id = p.id;
      ReadMatrix(r, &sighting.observation.z);
      ReadMatrix(r, &sighting.observation.Q);
    }
  }
}

using FailWith = std::function<void(const std::string&)>;

// Fails unless the filter's matrix is a well-formed upper triangle in compressed columns.
void CheckMatrixStructure(const MapFilterState& f, const FailWith& fail) {
  if (f.column_starts.size() != static_cast<size_t>(f.dim) + 1 || f.column_starts.front() != 0 ||
      f.column_starts.back() != static_cast<int>(f.rows.size())) {
    fail("the information matrix's column starts do not match its dimension and entries");
  }
  for (int c = 0; c < f.dim; ++c) {
    const int begin = f.column_starts[c], end = f.column_starts[c + 1];
    if (end < begin) fail("the information matrix's column " + std::to_string(c) + " is malformed");
    for (int k = begin; k < end; ++k) {
      if (f.rows[k] < 0 || f.rows[k] > c || (k > begin && f.rows[k] <= f.rows[k - 1])) {
        fail("the information matrix's column " + std::to_string(c) +
             " has rows out of order or below the diagonal");
      }
    }
  }
}

// Fails unless every feature id the map's pending features, keyframe observations and base
// frames name is among `ids` (the map's features) and every pending sighting's frame is a
// keyframe; the pending ids join `ids`.
void CheckReferences(const SavedMap& map, std::unordered_set<int64_t>* ids, const FailWith& fail) {
  // Pending features (seen by too few keyframes to be in the state) are the map's too: the
  // keyframes' observations and the base frames may name them. The filter's Restore checks
  // the rest of them.
  std::unordered_set<int> frames;
  for (const auto& [frame, offset] : map.filter.pose_offsets) frames.insert(frame);
  for (const PendingFeature& p : map.filter.pending) {
    if (p.id < 0 || !ids->insert(p.id).second) {
      fail("pending feature " + std::to_string(p.id) + " has a negative id or is listed twice");
    }
    for (const FeatureSighting& sighting : p.sightings) {
      if (frames.count(sighting.frame_id) == 0) {
        fail("pending feature " + std::to_string(p.id) + " is seen by frame " +
             std::to_string(sighting.frame_id) + ", which is no keyframe");
      }
    }
  }
  for (const MapKeyframe& k : map.keyframes) {
    for (const FeatureObservation& o : k.observations) {
      if (ids->count(o.feature_id) == 0) {
        fail("keyframe " + std::to_string(k.frame) + " observes feature " +
             std::to_string(o.feature_id) + ", which the map does not hold");
      }
    }
  }
  for (const MapBaseFrame& b : map.base_frames) {
    for (int64_t id : b.feature_ids) {
      if (id >= 0 && ids->count(id) == 0) {
        fail("base frame " + std::to_string(b.frame) + " names feature " + std::to_string(id) +
             ", which the map does not hold");
      }
    }
  }
}

// Throws DataError `where`: why, when the map's parts do not hold together.
void CheckConsistent(const SavedMap& map, const std::string& where) {
  const FailWith fail = [&](const std::string& why) { throw DataError(where + ": " + why); };
  const MapFilterState& f = map.filter;
  CheckMatrixStructure(f, fail);
  if (f.pose_offsets.size() != map.keyframes.size() ||
      f.feature_offsets.size() != map.features.size() ||
      map.base_frames.size() != map.keyframes.size()) {
    fail("the filter, keyframes, features and base frames do not count alike (" +
         std::to_string(f.pose_offsets.size()) + " poses, " + std::to_string(map.keyframes.size()) +
         " keyframes, " + std::to_string(f.feature_offsets.size()) + " filter features, " +
         std::to_string(map.features.size()) + " features, " +
         std::to_string(map.base_frames.size()) + " base frames)");
  }
  std::vector<int> covered(f.dim, 0);
  auto cover = [&](int offset, int n, const std::string& what) {
    if (offset < 0 || offset + n > f.dim) fail(what + " lies outside the state");
    for (int k = offset; k < offset + n; ++k) {
      if (covered[k]++ > 0) fail(what + " overlaps another variable");
    }
  };
  for (size_t k = 0; k < f.pose_offsets.size(); ++k) {
    const int frame = f.pose_offsets[k].first;
    if (map.keyframes[k].frame != frame || map.base_frames[k].frame != frame) {
      fail("keyframe " + std::to_string(k) + " is frame " + std::to_string(frame) +
           " in the filter but not in the keyframes or base frames");
    }
    cover(f.pose_offsets[k].second, 6, "pose of frame " + std::to_string(frame));
  }
  std::unordered_set<int64_t> ids;
  for (size_t k = 0; k < f.feature_offsets.size(); ++k) {
    const int64_t id = f.feature_offsets[k].first;
    if (id < 0) fail("feature " + std::to_string(id) + " has a negative id");
    if (map.features[k].id != id || !ids.insert(id).second) {
      fail("feature " + std::to_string(id) + " is listed twice or out of the filter's order");
    }
    cover(f.feature_offsets[k].second, 3, "feature " + std::to_string(id));
  }
  if (std::find(covered.begin(), covered.end(), 0) != covered.end()) {
    fail("part of the state belongs to no pose or feature");
  }
  CheckReferences(map, &ids, fail);
}

}  // namespace

SavedMap MakeSavedMap(const InformationFilter& filter, const SlamEstimate& estimate,
                      std::vector<MapBaseFrame> base_frames,
                      const std::map<int, std::vector<FeatureObservation>>& observations,
                      const Refinement* refinement, const Rig& rig, const std::string& options,
                      const std::string& dataset) {
  CHECK_EQ(static_cast<int>(base_frames.size()), filter.num_poses())
      << "one base frame per filter pose";
  SavedMap map;
  map.version = IeslamVersion();
  map.calibration = FormatCalibration(rig);
  map.options = options;
  map.dataset = dataset;

  SlamEstimate refined;
  if (refinement != nullptr && refinement->ok()) refined = SmootherEstimate(refinement->refined());
  for (size_t k = 0; k < base_frames.size(); ++k) {
    const int frame = filter.frame_ids()[k];
    CHECK_EQ(base_frames[k].frame, frame) << "base frames in the filter's order";
    MapKeyframe keyframe;
    keyframe.frame = frame;
    keyframe.timestamp = base_frames[k].timestamp;
    keyframe.pose = filter.pose(frame);
    const auto covariance = estimate.pose_covariances.find(frame);
    keyframe.covariance = covariance != estimate.pose_covariances.end()
                              ? covariance->second
                              : filter.PoseCovariance(frame);
    const auto it = refined.poses.find(frame);
    keyframe.refined = it != refined.poses.end();
    if (keyframe.refined) keyframe.refined_pose = it->second;
    const auto entered = observations.find(frame);
    if (entered != observations.end()) keyframe.observations = entered->second;
    map.keyframes.push_back(std::move(keyframe));
  }

  const std::vector<int64_t>& ids = filter.feature_ids();
  for (size_t first = 0; first < ids.size(); first += kFeaturesPerRecovery) {
    const size_t last = std::min(ids.size(), first + kFeaturesPerRecovery);
    std::vector<VariableRef> variables;
    for (size_t k = first; k < last; ++k) variables.push_back(VariableRef::Feature(ids[k]));
    const Eigen::MatrixXd covariance = filter.MarginalCovariance(variables);
    for (size_t k = first; k < last; ++k) {
      const int at = static_cast<int>(3 * (k - first));
      map.features.push_back({ids[k], filter.feature(ids[k]), covariance.block<3, 3>(at, at)});
    }
  }

  // Pending features keep their ids: a later session that sees them again brings them in.
  for (MapBaseFrame& b : base_frames) {
    for (int64_t& id : b.feature_ids) {
      if (id >= 0 && !filter.HasFeature(id) && !filter.IsPending(id)) id = -1;
    }
  }
  map.base_frames = std::move(base_frames);

  map.filter = filter.Snapshot();
  return map;
}

void WriteSavedMap(const std::string& dir, const SavedMap& map) {
  WriteSectionFile(JoinPath(dir, kMapFileName), kMapMagic, kMapFormatVersion, 5,
                   [&](SectionSink* sink) {
                     const auto whole = [&](const char* tag, const std::string& payload) {
                       sink->Begin(tag);
                       sink->Append(payload);
                       sink->End();
                     };
                     whole("META", WriteMeta(map));
                     whole("KFRM", WriteKeyframes(map));
                     whole("FEAT", WriteFeatures(map));
                     sink->Begin("BASE");
                     WriteBaseFrames(map, sink);
                     sink->End();
                     sink->Begin("FILT");
                     WriteFilter(map.filter, sink);
                     sink->End();
                   });
}

SavedMap ReadSavedMap(const std::string& dir) {
  const std::string path = JoinPath(dir, kMapFileName);
  const std::vector<FileSection> sections =
      ReadSectionFile(path, kMapMagic, kMapFormatVersion, "an ieslam map");
  const std::vector<std::string> tags = {"META", "KFRM", "FEAT", "BASE", "FILT"};
  std::string found;
  for (const FileSection& s : sections) found += (found.empty() ? "" : " ") + s.tag;
  if (sections.size() != tags.size() ||
      !std::equal(tags.begin(), tags.end(), sections.begin(),
                  [](const std::string& tag, const FileSection& s) { return s.tag == tag; })) {
    throw DataError(path + ": sections " + found + ", expected META KFRM FEAT BASE FILT");
  }
  SavedMap map;
  for (const FileSection& s : sections) {
    SectionReader r(s.payload, path + ": section '" + s.tag + "'");
    if (s.tag == "META") ReadMeta(&r, &map);
    if (s.tag == "KFRM") ReadKeyframes(&r, &map);
    if (s.tag == "FEAT") ReadFeatures(&r, &map);
    if (s.tag == "BASE") ReadBaseFrames(&r, &map);
    if (s.tag == "FILT") ReadFilter(&r, &map.filter);
    r.Finish();
  }
  CheckConsistent(map, path);
  return map;
}

std::string FindMapDirectory(const std::string& dir) {
  std::error_code ec;
  if (!std::filesystem::exists(JoinPath(dir, kMapFileName), ec) &&
      std::filesystem::exists(JoinPath(JoinPath(dir, kMapDirectory), kMapFileName), ec)) {
    return JoinPath(dir, kMapDirectory);
  }
  return dir;
}

FrameOrigin OriginIn(const Dataset& dataset, int frame, double shift_s) {
  FrameOrigin origin;
  origin.dataset = std::filesystem::absolute(dataset.directory()).lexically_normal().string();
  origin.source_index = dataset.info(frame).source_index;
  origin.timestamp = dataset.info(frame).timestamp - shift_s;
  return origin;
}

ProcessedFrame ProcessedBaseFrame(const MapBaseFrame& base, const FrameInfo& info) {
  ProcessedFrame processed;
  processed.info = info;
  processed.features = base.features;
  processed.points = base.points;
  return processed;
}

std::string LoadedMap::file() const { return JoinPath(directory, kMapFileName); }

LoadedMap LoadMap(const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  LoadedMap loaded;
  loaded.directory = FindMapDirectory(path);
  loaded.map = ReadSavedMap(loaded.directory);
  loaded.load_seconds = SecondsSince(start);
  return loaded;
}

void CheckMapCalibration(const SavedMap& map, const Rig& rig, const std::string& dir) {
  if (map.calibration != FormatCalibration(rig)) {
    throw DataError(JoinPath(dir, kMapFileName) +
                    ": made with another calibration than this dataset's (the map's:\n" +
                    map.calibration + ")");
  }
}

}  // namespace ieslam
