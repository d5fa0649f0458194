#include "apps/run_figures.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <type_traits>
#include <utility>
#include <vector>

#include "backend/information_filter.h"
#include "core/file_util.h"

namespace ieslam {

Json PoseSigmasToJson(const SlamEstimate& estimate, const std::map<int, double>& timestamps) {
  Json sigmas = Json::Array();
  for (const auto& [frame, P] : estimate.pose_covariances) {
    Json sigma = Json::Array();
    for (int i = 0; i < 6; ++i) sigma.Push(std::sqrt(std::max(0.0, P(i, i))));
    sigmas.Push(Json::Object()
                    .Set("frame", frame)
                    .Set("timestamp", timestamps.at(frame))
                    .Set("sigma", sigma));
  }
  return sigmas;
}

void WriteInformationBlocks(const InformationFilter& filter, const std::string& path) {
  // State blocks in state order, and the block of every state index.
  std::vector<std::pair<int, char>> starts;
  for (int frame : filter.frame_ids()) {
    starts.emplace_back(filter.StateIndex(VariableRef::Pose(frame)), 'P');
  }
  for (int64_t id : filter.feature_ids()) {
    starts.emplace_back(filter.StateIndex(VariableRef::Feature(id)), 'F');
  }
  std::sort(starts.begin(), starts.end());
  std::vector<int> block_of(filter.state_dim(), -1);
  std::string kinds;
  for (size_t b = 0; b < starts.size(); ++b) {
    const int size = starts[b].second == 'P' ? 6 : 3;
    for (int i = 0; i < size; ++i) block_of[starts[b].first + i] = static_cast<int>(b);
    kinds += starts[b].second;
  }
  std::set<std::pair<int, int>> pairs;
  const auto upper = filter.information_upper();
  for (int col = 0; col < upper.outerSize(); ++col) {
    for (std::decay_t<decltype(upper)>::InnerIterator it(upper, col); it; ++it) {
      const int a = block_of[it.row()], b = block_of[col];
      if (a != b && a >= 0 && b >= 0 && it.value() != 0.0)
        pairs.emplace(std::min(a, b), std::max(a, b));
    }
  }
  WriteFileAtomically(path, [&](std::ostream& out) {
    out << "# ieslam: nonzero blocks of the final information matrix, state order (P pose, F "
           "feature)\n";
    out << "blocks " << kinds << "\n";
    for (const auto& [a, b] : pairs) out << a << ' ' << b << "\n";
  });
}

}  // namespace ieslam
