// How good an O-Map is against ground truth (`oslam eval`): trajectory errors
// (ATE, RPE) of the estimate and of raw odometry, and objects matched one to
// one (Hungarian assignment on base-point distance, with a gate) with their
// position, size and class errors, true objects found and spurious objects.
#pragma once

#include <string>
#include <vector>

#include "core/run_folder.h"
#include "omap/omap.h"

namespace oslam {

struct MapMetricsOptions {
  double existence_threshold = 0.5;  // objects at or below it are not in the map
  double match_gate_m = 0.5;         // horizontal base-point distance for a match
  bool Validate(std::string* why) const;
};

struct TrajectoryMetrics {
  double ate_rmse_m = 0;            // absolute position error, no alignment (same first pose)
  double rpe_translation_rmse_m = 0;  // error of each frame-to-frame motion
  double rpe_rotation_rmse_rad = 0;
};

struct ObjectMatch {
  int true_id = 0;
  int map_id = 0;
  std::string true_class, map_class;
  double position_error_m = 0;  // 3D distance between base points
  double diameter_error_m = 0;  // map - truth
  double height_error_m = 0;
};

struct MapMetrics {
  TrajectoryMetrics estimate, odometry;
  std::vector<ObjectMatch> matches;
  int true_objects_total = 0;  // ground-truth objects with a class
  int true_objects_found = 0;  // = matches.size()
  int spurious_objects = 0;    // map objects above the threshold matched to nothing
  double object_position_error_median_m = 0;
  double diameter_error_mean_m = 0;  // mean of |error|
  double height_error_mean_m = 0;
  double class_accuracy = 0;         // matched objects whose class is right
  std::string Table() const;
  std::string Json() const;
};

// `map.trajectory` and `odometry` must have one pose per ground-truth frame;
// throws oslam::Error otherwise.
MapMetrics EvaluateMap(const OMap& map, const std::vector<Pose2>& odometry, const GroundTruth& truth,
                       const MapMetricsOptions& options = {});

// Minimum-cost one-to-one assignment of rows to columns (Hungarian method);
// cost[r][c] >= `forbidden` means the pair may not be matched. Returns the
// column of every row, or -1.
std::vector<int> MinCostAssignment(const std::vector<std::vector<double>>& cost, double forbidden);

}  // namespace oslam
