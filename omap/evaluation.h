// How good an O-Map is against ground truth (`oslam eval`, `oslam run`, and
// the summaries `oslam slam` and `oslam map` print): trajectory errors (ATE,
// RPE) of the estimate and of raw odometry, and objects matched one to one
// (Hungarian assignment on horizontal base-point distance, with a gate; or
// by object id when the map kept the true ids) with their position, size and
// class errors, true objects found and spurious objects.
#pragma once

#include <string>
#include <vector>

#include "core/run_folder.h"
#include "omap/omap.h"

namespace oslam {

enum class ObjectMatching {
  kNearest,  // Hungarian assignment on horizontal distance, within match_gate_m
  kById,     // a map object matches the true object of its id (known association), no gate
};

struct MapMetricsOptions {
  double existence_threshold = 0.5;  // objects at or below it are not in the map
  double match_gate_m = 0.5;         // horizontal base-point distance for a match
  ObjectMatching matching = ObjectMatching::kNearest;
  bool Validate(std::string* why) const;
};

struct TrajectoryMetrics {
  double ate_rmse_m = 0;              // absolute position error, no alignment (same first pose)
  double rpe_translation_rmse_m = 0;  // error of each frame-to-frame motion
  double rpe_rotation_rmse_rad = 0;
};

struct ObjectMatch {
  int true_id = 0;
  int map_id = 0;
  std::string true_class, map_class;
  double position_error_m = 0;    // 3D distance between base points
  double horizontal_error_m = 0;  // their distance on the floor (x, y)
  double diameter_error_m = 0;    // map - truth
  double height_error_m = 0;
};

struct MapMetrics {
  TrajectoryMetrics estimate, odometry;
  std::vector<ObjectMatch> matches;
  int true_objects_total = 0;               // ground-truth objects with a class
  int true_objects_found = 0;               // = matches.size()
  int spurious_objects = 0;                 // map objects above the threshold matched to nothing
  std::vector<std::string> missed_classes;  // class of each true object not found
  // Over the matches: 3D base-point distance, and horizontal (x, y) distance.
  double object_position_error_median_m = 0, object_position_error_max_m = 0;
  double object_horizontal_error_median_m = 0, object_horizontal_error_max_m = 0;
  double diameter_error_mean_m = 0;  // mean of |error|
  double height_error_mean_m = 0;
  int class_correct = 0;      // matched objects whose class is right
  double class_accuracy = 0;  // class_correct / matches
  // Table() and Json() are what `oslam eval` prints and writes (eval.json).
  std::string Table() const;
  std::string Json() const;
};

// `map.trajectory` and `odometry` must have one pose per ground-truth frame;
// throws oslam::Error otherwise.
MapMetrics EvaluateMap(const OMap& map, const std::vector<Pose2>& odometry,
                       const GroundTruth& truth, const MapMetricsOptions& options = {});

// Minimum-cost one-to-one assignment of rows to columns (Hungarian method);
// cost[r][c] >= `forbidden` means the pair may not be matched. Returns the
// column of every row, or -1.
std::vector<int> MinCostAssignment(const std::vector<std::vector<double>>& cost, double forbidden);

}  // namespace oslam
