#include "core/timestamp_association.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>

namespace ieslam {

std::vector<StampMatch> AssociateStamps(const std::vector<double>& first,
                                        const std::vector<double>& second, double offset,
                                        double max_diff) {
  CHECK(std::is_sorted(first.begin(), first.end()));
  CHECK(std::is_sorted(second.begin(), second.end()));
  struct Candidate {
    double diff;
    std::size_t a;
    std::size_t b;
  };
  // associate.py tests every (a, b); with b sorted, fl(a - fl(b + offset)) is monotone in b,
  // so the b passing the same floating-point test form one contiguous run per a.
  std::vector<Candidate> candidates;
  for (std::size_t a = 0; a < first.size(); ++a) {
    const double t = first[a];
    auto start = std::partition_point(second.begin(), second.end(),
                                      [&](double b) { return !(t - (b + offset) < max_diff); });
    for (auto it = start; it != second.end(); ++it) {
      const double diff = std::abs(t - (*it + offset));
      if (!(diff < max_diff)) break;
      candidates.push_back({diff, a, static_cast<std::size_t>(it - second.begin())});
    }
  }
  // As TUM: Python sorts the tuples (diff, a, b), so ties go to the smaller stamps.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    if (x.diff != y.diff) return x.diff < y.diff;
    if (x.a != y.a) return x.a < y.a;
    return x.b < y.b;
  });
  std::vector<bool> first_used(first.size(), false);
  std::vector<bool> second_used(second.size(), false);
  std::vector<StampMatch> matches;
  for (const Candidate& c : candidates) {
    if (first_used[c.a] || second_used[c.b]) continue;
    first_used[c.a] = true;
    second_used[c.b] = true;
    matches.push_back({c.a, c.b, first[c.a], second[c.b]});
  }
  std::sort(matches.begin(), matches.end(),
            [](const StampMatch& x, const StampMatch& y) { return x.first_index < y.first_index; });
  return matches;
}

}  // namespace ieslam
