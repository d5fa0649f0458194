// FLANN's headers must come before any OpenCV flann header in a file (their macros clash);
// this file includes no OpenCV flann header at all.
#include <flann/flann.hpp>

#include "frontend/matcher.h"

#include <algorithm>
#include <limits>

#include <Eigen/Core>
#include <glog/logging.h>

namespace ieslam {
namespace {

using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

Eigen::Map<const RowMatrixXf> AsEigen(const cv::Mat& m) {
  CHECK_EQ(m.type(), CV_32F);
  CHECK(m.isContinuous());
  return Eigen::Map<const RowMatrixXf>(m.ptr<float>(), m.rows, m.cols);
}

bool Fail(std::string* why, const std::string& message) {
  if (why != nullptr) *why = message;
  return false;
}

}  // namespace

bool MatchOptions::Check(std::string* why) const {
  if (!(ratio > 0.0 && ratio <= 1.0)) return Fail(why, "match.ratio must be in (0, 1]");
  return true;
}

bool DatabaseOptions::Check(std::string* why) const {
  if (trees < 1 || trees > 16) return Fail(why, "database.trees must be in [1, 16]");
  if (checks < 1) return Fail(why, "database.checks must be >= 1");
  if (neighbours < 2) return Fail(why, "database.neighbours must be >= 2");
  if (!(ratio > 0.0 && ratio <= 1.0)) return Fail(why, "database.ratio must be in (0, 1]");
  return true;
}

std::vector<DescriptorMatch> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                              const MatchOptions& options) {
  std::vector<DescriptorMatch> matches;
  if (query.rows == 0 || train.rows < 2) return matches;
  CHECK_EQ(query.cols, train.cols);
  const auto q = AsEigen(query);
  const auto t = AsEigen(train);
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

struct BaseFrameDatabase::Index {
  std::unique_ptr<flann::Index<flann::L2<float>>> flann;
};

BaseFrameDatabase::BaseFrameDatabase(const DatabaseOptions& options)
    : options_(options), index_(new Index) {
  std::string why;
  CHECK(options.Check(&why)) << why;
}

BaseFrameDatabase::~BaseFrameDatabase() = default;

bool BaseFrameDatabase::Contains(int frame_id) const {
  return std::find(frame_ids_.begin(), frame_ids_.end(), frame_id) != frame_ids_.end();
}

void BaseFrameDatabase::Add(int frame_id, const cv::Mat& descriptors) {
  CHECK(!Contains(frame_id)) << "frame " << frame_id << " added twice";
  CHECK_EQ(descriptors.type(), CV_32F);
  frame_ids_.push_back(frame_id);
  if (descriptors.rows == 0) return;
  descriptors_.push_back(descriptors.clone());
  cv::Mat& rows = descriptors_.back();
  row_frame_.insert(row_frame_.end(), rows.rows, num_frames() - 1);
  flann::Matrix<float> data(rows.ptr<float>(), rows.rows, rows.cols);
  // FLANN randomises its trees with std::rand; seeding it before every (re)build keeps the
  // index, and so the ranking, the same from run to run.
  flann::seed_random(options_.seed);
  if (!index_->flann) {
    index_->flann.reset(
        new flann::Index<flann::L2<float>>(data, flann::KDTreeIndexParams(options_.trees)));
    index_->flann->buildIndex();
  } else {
    index_->flann->addPoints(data, 2.0f);
  }
}

std::vector<std::pair<int, int>> BaseFrameDatabase::RankFrames(const cv::Mat& query,
                                                               int max_frames) const {
  std::vector<std::pair<int, int>> ranked;
  if (!index_->flann || query.rows == 0) return ranked;
  const int k = std::min<int>(options_.neighbours, static_cast<int>(row_frame_.size()));
  cv::Mat q = query.isContinuous() ? query : query.clone();
  flann::Matrix<float> queries(q.ptr<float>(), q.rows, q.cols);
  std::vector<std::vector<size_t>> indices;
  std::vector<std::vector<float>> dists;  // squared distances
  flann::SearchParams params(options_.checks);
  params.cores = 1;
  index_->flann->knnSearch(queries, indices, dists, k, params);

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
