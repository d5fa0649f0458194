// Descriptor matching: exact pairwise matching with Lowe's ratio test and a mutual check,
// and a FLANN kd-tree over the whole base-frame database to find which base frames a new
// frame shares features with (paper §IV: kd-tree matching against earlier frames).
//
// Pairwise matching is an exact search done as one matrix product of the descriptor sets,
// several times faster than FLANN for two frames' descriptors even with the index already
// built (docs/frontend_notes.md). The database is where an index wins: its size grows with
// every base frame while a query stays ~1000 descriptors.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/option_table.h"

namespace ieslam {

struct MatchOptions {
  double ratio = 0.8;  // Lowe's ratio on descriptor distances
  bool mutual = true;  // keep a match only if each is the other's nearest neighbour

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<MatchOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct DescriptorMatch {
  int query = -1;  // row in the query descriptors
  int train = -1;  // row in the train descriptors
  float distance = 0.0f;
};

// Matches rows of `query` to rows of `train` (CV_32F or CV_8U, same width). Deterministic.
std::vector<DescriptorMatch> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                              const MatchOptions& options);

struct DatabaseOptions {
  int trees = 1;       // randomised kd-trees (each costs a build; see matcher.cc)
  int checks = 64;     // leaves visited per query
  int neighbours = 6;  // k nearest descriptors looked at per query descriptor
  double ratio = 0.8;  // a neighbour votes when closer than ratio x the k-th distance
  unsigned seed = 1;   // FLANN's tree randomisation

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<DatabaseOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

// The descriptors of every base frame in one FLANN index: each frame's descriptors are added
// once, the index is rebuilt when a base frame is added and never per query.
class BaseFrameDatabase {
 public:
  // Throws ConfigError for options failing Check().
  explicit BaseFrameDatabase(const DatabaseOptions& options);
  ~BaseFrameDatabase();
  BaseFrameDatabase(const BaseFrameDatabase&) = delete;
  BaseFrameDatabase& operator=(const BaseFrameDatabase&) = delete;

  // Adds a frame's descriptors (copied; CV_32F or CV_8U, the type of the first frame added
  // for every frame). Frame ids must be unique.
  void Add(int frame_id, const cv::Mat& descriptors);
  int num_frames() const { return static_cast<int>(frame_ids_.size()); }
  // Frees every frame's descriptors and the index: the database is empty again.
  void Clear();
  bool Contains(int frame_id) const;

  // Base frames ranked by the number of query descriptors (of the type the database holds)
  // that vote for them (most first, ties by frame id), at most `max_frames` of them: the
  // candidates for exact matching and registration.
  std::vector<std::pair<int, int>> RankFrames(const cv::Mat& query, int max_frames) const;

 private:
  struct Index;
  // Per query row, (squared distance, database row) of its k nearest database rows, nearest
  // first: the index's approximate neighbours merged with the exact search of the tail.
  std::vector<std::vector<std::pair<float, int>>> Nearest(const cv::Mat& query, int k) const;
  // Rows added since the last build that are searched exactly before a rebuild is due.
  static constexpr int kMinTailRows = 2048;
  static constexpr int kTailFraction = 16;
  DatabaseOptions options_;
  std::unique_ptr<Index> index_;
  std::vector<int> frame_ids_;  // per added frame
  std::vector<int> row_frame_;  // per database row: position in frame_ids_
};

}  // namespace ieslam
