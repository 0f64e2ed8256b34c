// What an association recovered with the ids hidden is scored against
// (docs/method.md §16.2, docs/results.md): the file's own association, with
// its two kinds of front-end error made explicit instead of counted against
// the search. A file may give one tree two ids (two landmarks solved
// centimetres apart that no scan sees together), and may tie a sighting to
// the wrong tree (a sighting its own solve leaves many sigmas off under the
// calibrated noise). Both are reported beside the plain comparison, never
// instead of it.
#pragma once

#include <limits>
#include <vector>

#include "slam/landmark_data.h"
#include "slam/landmark_slam.h"

namespace oslam {

// `ids` with the landmarks of `solved` (a solve of `ids`) that lie within
// `radius_m` of each other and share no scan given one id (the lower one's).
// `joined` (if given) receives the number of landmarks joined into another.
std::vector<int> JoinDuplicateLandmarks(const LandmarkDataset& data, const std::vector<int>& ids,
                                        const LandmarkSlamResult& solved, double radius_m,
                                        int* joined = nullptr);

// Data snooping's batch at a solve `solved` of `ids`: of each landmark with
// at least `min_sightings` sightings, the worst sighting whose squared
// whitened error exceeds `gate`, kept only within a factor 4 of the worst of
// all (a wrong sighting bends the solve around it, so its neighbours misfit
// too); worst first.
std::vector<int> WorstMisfitSightings(const LandmarkDataset& data, const std::vector<int>& ids,
                                      const LandmarkSlamResult& solved, double gate,
                                      int min_sightings = 1);

// The sightings of `ids` whose squared whitened error at the solve of `ids`
// exceeds `gate` (2 degrees of freedom; 25 is the noise calibration's gate)
// set to -1, re-solved until none exceeds it (at most `rounds` times). Data
// snooping (Baarda) in batches: each round leaves out only the worst
// sighting of each landmark, and only those within a factor 4 of the
// round's worst error, since a wrong sighting bends the solve around it;
// one left out that fits a later solve is taken back. The
// solve is returned in `solved` (if given), the sightings left out in
// `removed` (if given).
std::vector<int> LeaveOutOutlierSightings(const LandmarkDataset& data, std::vector<int> ids,
                                          const LandmarkSlamOptions& options, double gate,
                                          LandmarkSlamResult* solved = nullptr,
                                          int* removed = nullptr, int rounds = 100);

// A sighting's squared whitened error at a solve and its deleted one.
struct SightingErrors {
  double at_solve = std::numeric_limits<double>::quiet_NaN();
  double deleted = std::numeric_limits<double>::quiet_NaN();
};

// Deleted residuals (Cook and Weisberg's studentised residuals, in the
// whitened metric): for each of `sightings` (indices into data.sightings
// with ids[k] >= 0), its squared whitened error e^T e at the solve of `ids`
// and its error against the solve without it, as e and its whitened
// Jacobian J in the pose and the landmark give it: e^T (I - J S J^T)^{-1} e,
// S their joint covariance at the solve. A sighting the map turned to fit
// (the only one tying a landmark to a stretch of the drive) has a small
// e^T e but J S J^T near I. `slam`'s last Solve must be that of `ids` giving
// `solved`; poses below `held_poses` (and pose 0) count as fixed. `deleted`
// is infinity where I - J S J^T is not positive definite; both are NaN where
// not computable (no such landmark, the landmark on the sensor, no
// covariance).
std::vector<SightingErrors> DeletedSightingErrors(
    const LandmarkDataset& data, const std::vector<int>& ids, const LandmarkSlamResult& solved,
    LandmarkSlam* slam, const std::vector<int>& sightings, int held_poses = 0);

}  // namespace oslam
