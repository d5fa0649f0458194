// A bundle-adjustment problem on disk, so that a run can be refined again later (other
// options, a robust loss, more iterations) without re-running the front end and the filter:
// `ieslam run` writes OUT/ba_problem.txt, `ieslam refine` reads it.
//
// Text, one record per line, values printed with 17 significant digits so that reading
// gives back exactly what was written (the refinement from the file is bit-identical to the
// one inside the run):
//   # comments
//   ieslam_ba_problem 3 <poses> <features> <observations> <registered>
//   camera <width> <height> <fx> <fy> <cx> <cy>        (undistorted observations)
//   anchor <frame>
//   pose <frame> <timestamp> <r00 r01 r02 r10 r11 r12 r20 r21 r22> <tx ty tz>   (T_w_c)
//   feature <id> <x y z>                                (world)
//   obs <frame> <feature id> <u v d> <Q00 Q01 Q02 Q11 Q12 Q22>
//   registered <frame> <feature id> <u v d> <Q00 Q01 Q02 Q11 Q12 Q22>   (see below)
//   end
// `registered` records are BundleAdjustmentProblem::registered, after every `obs` record.
// The header's counts and the end line tell a complete file from one cut short, even at a
// line boundary. Version 1 files (without them) are refused: they cannot be checked. Version 2
// files (three counts, no registered observations) are read.
#pragma once

#include <map>
#include <string>

#include "backend/bundle_adjustment.h"
#include "core/camera.h"

namespace ieslam {

struct StoredBaProblem {
  BundleAdjustmentProblem problem;
  PinholeCamera camera;
  std::map<int, double> timestamps;  // per pose, seconds
};

// Writes atomically. CHECK-fails when a pose has no timestamp.
void WriteBaProblem(const std::string& path, const StoredBaProblem& stored);

// Throws DataError naming the file and line for a missing file, another version, an unknown
// record, a malformed or non-finite value, a duplicate pose or feature, an observation of an
// unknown pose or feature, one outside the image by more than the image's size or with a range
// d <= 0, a Q that is not symmetric positive definite, records after the end line, and naming
// the file and what is missing for a file without its end line or with fewer records than its
// header counts.
StoredBaProblem ReadBaProblem(const std::string& path);

}  // namespace ieslam
