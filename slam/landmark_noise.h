// Noise calibration of planar landmark SLAM by variance components
// (docs/method.md §16.3): the stated noise of a data set's sightings and
// odometry scaled, per group, so that each group's squared whitened
// residuals match their redundancy at the solution of a given association
// (Helmert / Förstner variance-component estimation, iterated). The evidence
// that compares associations is only as good as this noise: GTSAM's
// Victoria Park file states a bearing std of 0.2 rad for a laser, under
// which merging trees metres apart pays.
#pragma once

#include <string>
#include <vector>

#include "slam/landmark_data.h"
#include "slam/landmark_slam.h"

namespace oslam {

// Variance factors (the covariances are multiplied by them).
struct NoiseScales {
  double range = 1, bearing = 1;  // range-bearing sightings' two rows
  double point = 1;               // Cartesian sightings
  double odometry_translation = 1, odometry_heading = 1;
};

struct NoiseCalibrationOptions {
  int iterations = 3;
  // Factors whose squared whitened error (under the scales so far) exceeds
  // this are left out of the estimate, sightings also out of the later
  // solves: wrong associations must not inflate the noise.
  double outlier_gate = 25;
  // A group's scale is estimated only with at least this much redundancy.
  double min_redundancy = 10;
  double min_scale = 1e-4, max_scale = 1e4;
  // The redundancy of each row, 1 - (J Sigma J^T)_ii, is estimated from this
  // many draws of the solution's Gaussian (a covariance block per factor
  // would cost a sparse solve per variable); a group sums thousands of rows,
  // so its redundancy is far more precise than one row's.
  int redundancy_samples = 200;
  unsigned long seed = 1;
  // The solve under the final scales (NoiseCalibrationResult::solution);
  // off when only the scales are wanted (the solution is then the last
  // iteration's, under the scales before).
  bool final_solve = true;

  bool Validate(std::string* why) const;
};

struct NoiseCalibrationResult {
  NoiseScales scales;
  // Redundancy (degrees of freedom) of each group at the last iteration:
  // range, bearing, point, odometry translation, odometry heading.
  double redundancy[5] = {0, 0, 0, 0, 0};
  // Factors gated out: sightings at any iteration (left out of the later
  // solves), odometry edges at the last.
  int outliers = 0;
  LandmarkSlamResult solution;  // of the data set with the final scales
  double time_s = 0;
};

// Scales the noise of every sighting and odometry edge (heading rows and
// columns by sqrt(odometry_heading), translation ones by
// sqrt(odometry_translation)).
LandmarkDataset WithNoiseScales(const LandmarkDataset& data, const NoiseScales& scales);

// Solves `association` under `slam` (warm-started when given), estimates the
// scales, and repeats `iterations` times. Throws oslam::Error on invalid
// options or when a solve fails.
NoiseCalibrationResult CalibrateNoise(const LandmarkDataset& data,
                                      const std::vector<int>& association,
                                      const LandmarkSlamOptions& slam,
                                      const NoiseCalibrationOptions& options,
                                      const LandmarkSlamResult* warm_start = nullptr);

}  // namespace oslam
