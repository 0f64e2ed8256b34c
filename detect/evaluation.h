// Detections against the simulator's ground truth: precision and recall per
// class, class confusions, and bounding-slice errors in pixels.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "calib/camera_model.h"

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
  int sightings = 0;        // counted for recall
  int sightings_found = 0;  // of those, matched by a detection of the right class
  int detections = 0;       // of this class
  int true_positives = 0;   // on an object of this class
  int confused = 0;         // on an object of another class
  int spurious = 0;         // on no class object (distractor or background)
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

// One row of RUN/ground_truth/visible_slices.csv: the slice of an object's
// visible pixels in a frame (what a pixel-exact detector would report).
struct VisibleSlice {
  long frame = 0;
  int object_id = 0;
  long visible_px = 0, footprint_px = 0;
  BoundingSlice slice;
};
// Reads it; throws "FILE:LINE: ..." on a bad row. Empty when the file is absent.
std::vector<VisibleSlice> ReadVisibleSlices(const std::string& run_dir);

// Mean and standard deviation of signed slice errors (u_r, u_phi, s_r, s_phi),
// all in pixels (angles as arc length at the true base radius).
struct SignedSliceErrors {
  int count = 0;
  std::array<double, 4> mean{}, std{};
};

// Where a class's slice errors come from (docs/detection.md, "Signed slice
// errors"), over the unoccluded sightings that count for recall:
//   detector   = best detection - the visible slice (the detector's share);
//   section    = visible slice - the thesis' cylinder section (A.7-A.10);
//   silhouette = visible slice - the silhouette model of the object's true
//                shape (docs/method.md §4.2), the model oslam run fits.
struct ClassSliceErrors {
  std::string class_name;
  SignedSliceErrors detector, section, silhouette;
};

std::vector<ClassSliceErrors> SignedSliceErrorsPerClass(
    const std::vector<Detection>& detections, const GroundTruth& truth,
    const std::vector<VisibleSlice>& visible, const std::vector<ObjectClass>& classes,
    const CameraModel& camera, const DetectionEvaluationOptions& options = {});
std::string SignedSliceErrorsTable(const std::vector<ClassSliceErrors>& errors);
std::string SignedSliceErrorsJson(const std::vector<ClassSliceErrors>& errors);

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
