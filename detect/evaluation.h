// Detections against the simulator's ground truth: precision and recall per
// class, class confusions, and bounding-slice errors in pixels.
#pragma once

#include <string>
#include <vector>

#include "core/run_folder.h"
#include "detect/blob_detector.h"

namespace oslam {

struct DetectionEvaluationOptions {
  // A sighting counts for recall when at least this share of it is visible and
  // the object's base is within max_range_m of the robot (the issue's "unoccluded
  // objects within 3 m").
  double min_visible_fraction = 0.9;
  double max_range_m = 3.0;
  // A detection matches a sighting when their slices overlap radially and
  // angularly, with this many pixels (of arc, at the base radius) of tolerance.
  double slack_px = 3.0;
};

struct ClassDetectionStats {
  std::string class_name;
  int sightings = 0;            // counted for recall
  int sightings_found = 0;      // of those, matched by a detection of the right class
  int detections = 0;           // of this class
  int true_positives = 0;       // on an object of this class
  int confused = 0;             // on an object of another class
  int spurious = 0;             // on no class object (distractor or background)
  double Recall() const { return sightings ? double(sightings_found) / sightings : 0.0; }
  double Precision() const { return detections ? double(true_positives) / detections : 0.0; }
};

struct DetectionEvaluation {
  std::vector<ClassDetectionStats> per_class;
  ClassDetectionStats total;
  // Over the best (largest) matching detection of each recall sighting:
  // median absolute errors, pixels (angles as arc length at the base radius).
  double median_u_r_error_px = 0, median_u_phi_error_px = 0;
  double median_s_r_error_px = 0, median_s_phi_error_px = 0;
  double median_position_error_px = 0;  // |base point detected - true| in the image
  // counts[c][a]: detections of class a on an object of class c (a detection
  // on an object of its own class counts there even if others overlap it).
  std::vector<std::vector<int>> confusion_counts;
  std::string Table() const;
  std::string Json() const;
};

DetectionEvaluation EvaluateDetections(const std::vector<Detection>& detections,
                                       const GroundTruth& truth,
                                       const std::vector<ObjectClass>& classes,
                                       const DetectionEvaluationOptions& options = {});

// P(detected a | true c) measured from confusion counts (docs/method.md §7.1, what
// the thesis estimated on training data): rows normalised, entries floored at
// `floor` and renormalised; a class with no detection gets the identity row.
// matrix[c][a], like ColourConfusion.
std::vector<std::vector<double>> ConfusionFromCounts(const std::vector<std::vector<int>>& counts,
                                                     double floor = 1e-3);

}  // namespace oslam
