#include "frontend/matcher.h"

#include <algorithm>
#include <limits>

#include <glog/logging.h>
#include <Eigen/Core>
#include <opencv2/flann.hpp>

#include "core/error.h"

namespace ieslam {
namespace {

using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Eigen::Map<const RowMatrixXf> AsEigen(const cv::Mat& m) {
  CHECK_EQ(m.type(), CV_32F);
  CHECK(m.isContinuous());
  return Eigen::Map<const RowMatrixXf>(m.ptr<float>(), m.rows, m.cols);
}

// Descriptor rows as the distance computations take them: continuous CV_32F, bytes
// converted (exactly: every byte is a float).
cv::Mat AsFloatRows(const cv::Mat& m) {
  CHECK(m.type() == CV_32F || m.type() == CV_8U) << "descriptor type " << m.type();
  if (m.type() == CV_32F) return m.isContinuous() ? m : m.clone();
  cv::Mat rows;
  m.convertTo(rows, CV_32F);
  return rows;
}

}  // namespace

const OptionTable<MatchOptions>& MatchOptions::Table() {
  static const OptionTable<MatchOptions>* table = [] {
    using O = MatchOptions;
    auto* t = new OptionTable<O>;
    t->Double("ratio", &O::ratio, "Lowe's ratio").Above(0.0).Max(1.0);
    t->Bool("mutual", &O::mutual, "keep a match only if each is the other's nearest");
    return t;
  }();
  return *table;
}

const OptionTable<DatabaseOptions>& DatabaseOptions::Table() {
  static const OptionTable<DatabaseOptions>* table = [] {
    using O = DatabaseOptions;
    auto* t = new OptionTable<O>;
    t->Int("trees", &O::trees, "FLANN's randomised kd-trees").Range(1, 16);
    t->Int("checks", &O::checks, "leaves visited per query").Min(1);
    t->Int("neighbours", &O::neighbours, "nearest descriptors looked at per query").Min(2);
    t->Double("ratio", &O::ratio, "a neighbour votes when closer than ratio x the k-th")
        .Above(0.0)
        .Max(1.0);
    t->Uint("seed", &O::seed, "FLANN's tree randomisation: the run's seed").Derived();
    return t;
  }();
  return *table;
}

std::vector<DescriptorMatch> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                              const MatchOptions& options) {
  std::vector<DescriptorMatch> matches;
  if (query.rows == 0 || train.rows < 2) return matches;
  CHECK_EQ(query.cols, train.cols);
  const cv::Mat query_rows = AsFloatRows(query), train_rows = AsFloatRows(train);
  const auto q = AsEigen(query_rows);
  const auto t = AsEigen(train_rows);
  // |q - t|^2 = |q|^2 + |t|^2 - 2 q.t, all pairs at once.
  const Eigen::VectorXf q_norm = q.rowwise().squaredNorm();
  const Eigen::RowVectorXf t_norm = t.rowwise().squaredNorm().transpose();
  RowMatrixXf d2 = -2.0f * (q * t.transpose());
  d2.colwise() += q_norm;
  d2.rowwise() += t_norm;

  std::vector<int> best_query_of_train;
  if (options.mutual) {
    best_query_of_train.resize(t.rows());
    for (int j = 0; j < d2.cols(); ++j) d2.col(j).minCoeff(&best_query_of_train[j]);
  }
  const float ratio2 = static_cast<float>(options.ratio * options.ratio);
  for (int i = 0; i < d2.rows(); ++i) {
    float best = std::numeric_limits<float>::max(), second = best;
    int best_j = -1;
    for (int j = 0; j < d2.cols(); ++j) {
      const float d = d2(i, j);
      if (d < best) {
        second = best;
        best = d;
        best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (!(best < ratio2 * second)) continue;
    if (options.mutual && best_query_of_train[best_j] != i) continue;
    matches.push_back({i, best_j, std::sqrt(std::max(best, 0.0f))});
  }
  return matches;
}

// The FLANN copy inside OpenCV: Debian's libflann shuffles its randomised trees with
// std::random_device, so no seed makes its index (and the ranking) repeatable; OpenCV's copy
// draws from cv::theRNG, which cvflann::seed_random seeds. Its index cannot grow, so the
// rows added since the last build (the tail) are searched exactly, and the index is rebuilt
// once the tail passes 1/kTailFraction of the indexed rows: geometric growth bounds the total
// build cost by a constant times the final build. One tree and a 1/16 tail rank as well as
// more trees and a longer tail at a fraction of the cost (docs/frontend_notes.md).
//
// The tree is OpenCV's header template over the rows' own type: bytes stay bytes (no float
// copy, and a quarter of the cache lines each distance reads), and the squared distances are
// the same integers either way, exact in float.
class KdTree {
 public:
  virtual ~KdTree() = default;
  // The k (at most the indexed rows) nearest indexed rows of each query row (of the tree's
  // type, which RankFrames checks), nearest first: row indices (CV_32S) and squared distances
  // (CV_32F).
  virtual void Search(const cv::Mat& query, int k, int checks, cv::Mat* indices,
                      cv::Mat* dists) const = 0;
};

template <typename T>
class KdTreeOf : public KdTree {
 public:
  // `rows` (continuous) is shared, not copied: the header keeps its buffer alive.
  KdTreeOf(const cv::Mat& rows, int trees)
      : rows_(rows),
        tree_(cvflann::Matrix<T>(const_cast<T*>(rows_.ptr<T>()), rows_.rows, rows_.cols),
              cvflann::KDTreeIndexParams(trees)) {
    CHECK(rows_.isContinuous());
    tree_.buildIndex();
  }
  void Search(const cv::Mat& query, int k, int checks, cv::Mat* indices,
              cv::Mat* dists) const override {
    const cv::Mat q = query.isContinuous() ? query : query.clone();
    indices->create(q.rows, k, CV_32S);
    dists->create(q.rows, k, CV_32F);
    cvflann::Matrix<int> i(indices->ptr<int>(), q.rows, k);
    cvflann::Matrix<float> d(dists->ptr<float>(), q.rows, k);
    tree_.knnSearch(cvflann::Matrix<T>(const_cast<T*>(q.ptr<T>()), q.rows, q.cols), i, d, k,
                    cvflann::SearchParams(checks));
  }

 private:
  cv::Mat rows_;
  // knnSearch is not const in cvflann, though a search leaves the tree as it was.
  mutable cvflann::KDTreeIndex<cvflann::L2<T>> tree_;
};

struct BaseFrameDatabase::Index {
  cv::Mat storage;  // capacity for rows
  cv::Mat rows;     // every base frame's descriptors, in the order added (in storage)
  int indexed = 0;  // rows [0, indexed) are in `tree`
  std::unique_ptr<KdTree> tree;
};

BaseFrameDatabase::BaseFrameDatabase(const DatabaseOptions& options)
    : options_(options), index_(new Index) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
}

BaseFrameDatabase::~BaseFrameDatabase() = default;

void BaseFrameDatabase::Clear() {
  index_ = std::make_unique<Index>();
  frame_ids_ = {};
  row_frame_ = {};
}

bool BaseFrameDatabase::Contains(int frame_id) const {
  return std::find(frame_ids_.begin(), frame_ids_.end(), frame_id) != frame_ids_.end();
}

void BaseFrameDatabase::Add(int frame_id, const cv::Mat& descriptors) {
  CHECK(!Contains(frame_id)) << "frame " << frame_id << " added twice";
  CHECK(descriptors.type() == CV_32F || descriptors.type() == CV_8U);
  CHECK(index_->rows.empty() || descriptors.type() == index_->rows.type());
  frame_ids_.push_back(frame_id);
  if (descriptors.rows == 0) return;
  row_frame_.insert(row_frame_.end(), descriptors.rows, num_frames() - 1);
  // Rows are appended into storage that grows geometrically: each row is copied O(1) times.
  const int n = index_->rows.rows, m = descriptors.rows;
  if (index_->storage.rows < n + m) {
    cv::Mat grown(std::max(2 * index_->storage.rows, n + m), descriptors.cols, descriptors.type());
    if (n > 0) index_->rows.copyTo(grown.rowRange(0, n));
    index_->storage = grown;
  }
  descriptors.copyTo(index_->storage.rowRange(n, n + m));
  index_->rows = index_->storage.rowRange(0, n + m);  // full-width rows: continuous
  const int tail = index_->rows.rows - index_->indexed;
  if (tail <= std::max(kMinTailRows, index_->indexed / kTailFraction)) return;
  cvflann::seed_random(options_.seed);
  if (index_->rows.type() == CV_8U) {
    index_->tree = std::make_unique<KdTreeOf<unsigned char>>(index_->rows, options_.trees);
  } else {
    index_->tree = std::make_unique<KdTreeOf<float>>(index_->rows, options_.trees);
  }
  index_->indexed = index_->rows.rows;
}

std::vector<std::vector<std::pair<float, int>>> BaseFrameDatabase::Nearest(const cv::Mat& query,
                                                                           int k) const {
  // Per query row, (squared distance, database row) of its k nearest: the index's, then
  // merged with the exact tail's.
  std::vector<std::vector<std::pair<float, int>>> nearest(query.rows);
  if (index_->tree) {
    cv::Mat indices, dists;
    index_->tree->Search(query, std::min(k, index_->indexed), options_.checks, &indices, &dists);
    for (int i = 0; i < query.rows; ++i) {
      for (int n = 0; n < indices.cols; ++n) {
        if (indices.at<int>(i, n) >= 0) {
          nearest[i].emplace_back(dists.at<float>(i, n), indices.at<int>(i, n));
        }
      }
    }
  }
  // The k nearest of each row's candidates, ordered by (distance, row): the index's k and
  // the exact tail's, kept by insertion while the tail is scanned in column blocks (no
  // per-row list of every tail row, no full distance matrix of a long tail).
  for (auto& candidates : nearest) std::sort(candidates.begin(), candidates.end());
  const int tail = index_->rows.rows - index_->indexed;
  if (tail > 0) {
    const cv::Mat q = AsFloatRows(query);
    const auto qe = AsEigen(q);
    const Eigen::VectorXf q_norm = qe.rowwise().squaredNorm();
    constexpr int kBlock = 512;
    RowMatrixXf d2;
    for (int begin = index_->indexed; begin < index_->rows.rows; begin += kBlock) {
      const int end = std::min(begin + kBlock, index_->rows.rows);
      const cv::Mat block = AsFloatRows(index_->rows.rowRange(begin, end));
      const auto te = AsEigen(block);
      d2.noalias() = -2.0f * (qe * te.transpose());
      d2.colwise() += q_norm;
      d2.rowwise() += te.rowwise().squaredNorm().transpose();
      for (int i = 0; i < query.rows; ++i) {
        auto& best = nearest[i];
        for (int j = 0; j < end - begin; ++j) {
          const std::pair<float, int> candidate(std::max(d2(i, j), 0.0f), begin + j);
          if (static_cast<int>(best.size()) == k && !(candidate < best.back())) continue;
          best.insert(std::upper_bound(best.begin(), best.end(), candidate), candidate);
          if (static_cast<int>(best.size()) > k) best.pop_back();
        }
      }
    }
  }
  return nearest;
}

std::vector<std::pair<int, int>> BaseFrameDatabase::RankFrames(const cv::Mat& query,
                                                               int max_frames) const {
  std::vector<std::pair<int, int>> ranked;
  if (index_->rows.empty() || query.rows == 0) return ranked;
  CHECK_EQ(query.type(), index_->rows.type()) << "query descriptors of another type than the "
                                                 "database's";
  const int k = std::min<int>(options_.neighbours, index_->rows.rows);
  const std::vector<std::vector<std::pair<float, int>>> nearest = Nearest(query, k);
  std::vector<std::vector<size_t>> indices(query.rows);
  std::vector<std::vector<float>> dists(query.rows);
  for (int i = 0; i < query.rows; ++i) {
    const size_t keep = std::min<size_t>(k, nearest[i].size());
    for (size_t n = 0; n < keep; ++n) {
      dists[i].push_back(nearest[i][n].first);
      indices[i].push_back(static_cast<size_t>(nearest[i][n].second));
    }
  }

  std::vector<int> votes(frame_ids_.size(), 0);
  std::vector<int> voted;
  const float ratio2 = static_cast<float>(options_.ratio * options_.ratio);
  for (size_t i = 0; i < indices.size(); ++i) {
    if (indices[i].empty()) continue;
    const float reference = dists[i].back();
    voted.clear();
    for (size_t n = 0; n < indices[i].size(); ++n) {
      if (!(dists[i][n] < ratio2 * reference)) break;
      const int frame = row_frame_[indices[i][n]];
      // One vote per query descriptor and frame.
      if (std::find(voted.begin(), voted.end(), frame) == voted.end()) {
        voted.push_back(frame);
        ++votes[frame];
      }
    }
  }
  for (size_t f = 0; f < votes.size(); ++f) {
    if (votes[f] > 0) ranked.emplace_back(frame_ids_[f], votes[f]);
  }
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  if (static_cast<int>(ranked.size()) > max_frames) ranked.resize(max_frames);
  return ranked;
}

}  // namespace ieslam
