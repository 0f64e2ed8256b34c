// Measures of an estimated association and trajectory against a reference
// (the true ids, or another solve of the same data).
#pragma once

#include <vector>

#include "core/pose2.h"

namespace oslam {

// Pairwise comparison of two associations of the same sightings (ids need
// not match; -1 = a landmark of its own): over all pairs of sightings,
// "same landmark" in one vs the other.
struct PairwiseAgreement {
  long long pairs = 0, same_both = 0, same_estimate = 0, same_truth = 0;
  double agreement = 0;  // share of pairs on which both agree (same or different)
  double precision = 0;  // same_both / same_estimate (1 when no pair is "same")
  double recall = 0;     // same_both / same_truth (1 when no pair is "same")
};
// Throws oslam::Error when the sizes differ.
PairwiseAgreement ComparePairwise(const std::vector<int>& estimate, const std::vector<int>& truth);

// RMS of the position differences of two trajectories of the same poses (m),
// without alignment. Throws oslam::Error when the sizes differ or both are
// empty.
double TrajectoryRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b);

// The same after the least-squares rigid motion of `a` onto `b` (the
// absolute trajectory error of Sturm et al., IROS 2012, in the plane): the
// map's shape, whatever the frame its first poses pin it to. Throws as above.
double AlignedTrajectoryRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b);

}  // namespace oslam
