// Scores an O-Map against the simulator's ground truth (issue 7's measures):
// trajectory error against odometry's, true objects found and spurious
// objects at existence probability > threshold, class accuracy of the found
// objects, position error.
#pragma once

#include <string>
#include <vector>

#include "core/motion_model.h"
#include "core/run_folder.h"
#include "omap/omap.h"

namespace oslam {

struct OMapScoreOptions {
  double existence_threshold = 0.5;
  double match_distance_m = 0.5;  // horizontal distance of a base point to a true object
};

struct OMapScore {
  double trajectory_rmse_m = 0, odometry_rmse_m = 0;  // ATE, no alignment (same first pose)
  int true_objects = 0;                               // ground-truth objects with a class
  int found = 0;          // of them, matched by a map object above the threshold
  int spurious = 0;       // map objects above the threshold matched to none
  int class_correct = 0;  // found objects whose map class is the true class
  double position_median_m = 0, position_max_m = 0;  // horizontal, over found objects
  std::vector<std::string> missed;                   // class names of the missed objects
};

OMapScore ScoreOMap(const OMap& map, const std::vector<Pose2>& odometry, const GroundTruth& truth,
                    const OMapScoreOptions& options = {});

}  // namespace oslam
