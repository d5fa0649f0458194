// Pairing two lists of timestamps as TUM's associate.py does (Sturm et al., IROS 2012): the
// rule that pairs a TUM sequence's colour and depth images, a pair dataset's colour and
// range images, and an estimated trajectory with its ground truth.
#pragma once

#include <cstddef>
#include <vector>

namespace ieslam {

// One association: indices into the two stamp lists and the stamps themselves.
struct StampMatch {
  std::size_t first_index = 0;
  std::size_t second_index = 0;
  double first_stamp = 0.0;
  double second_stamp = 0.0;
};

// associate.py: candidate pairs (a, b) with |a - (b + offset)| < max_diff, taken greedily in
// order of increasing |a - (b + offset)| (ties by a, then b) while neither stamp is used;
// the result is sorted by the first stamp. Both lists must be sorted ascending (CHECK).
std::vector<StampMatch> AssociateStamps(const std::vector<double>& first,
                                        const std::vector<double>& second, double offset,
                                        double max_diff);

}  // namespace ieslam
