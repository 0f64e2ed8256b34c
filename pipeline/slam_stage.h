// The O-SLAM stage (docs/method.md §6-§9, Algorithm 9) on a run folder's detections:
// tracks, hill climbing, MC³ over (C, J), fusion of the samples into an
// O-Map with existence probabilities and class histograms; or the
// nearest-neighbour baseline. Writes the O-Map and reports convergence and,
// when the run has ground truth, its scores.
#pragma once

#include <string>
#include <vector>

#include "association/nn_baseline.h"
#include "association/omap_fusion.h"
#include "association/sampled_omap.h"
#include "association/sampler.h"
#include "association/slam_target.h"
#include "association/tracks.h"
#include "detect/blob_detector.h"
#include "pipeline/stage_output.h"

namespace oslam {

enum class SlamMethod { kOSlam, kNearestNeighbour };
const char* SlamMethodName(SlamMethod method);  // "oslam", "nn"

struct SlamStageOptions {
  // Tracks are joined across 2 missed frames (occlusions; beyond the
  // thesis, whose 0 is TrackOptions' default).
  SlamStageOptions() { tracks.max_gap_frames = 2; }

  SlamMethod method = SlamMethod::kOSlam;
  TrackOptions tracks;
  SlamTargetOptions target;  // E, motion noise Q, solver, P(C, J)
  SamplerOptions sampler;    // MC3, moves
  FusionOptions fusion;      // spurious model, identity merging
  NearestNeighbourOptions baseline;
  double confusion_floor = 1e-3;  // smallest P(a | c) (docs/method.md §13 #12)
  double location_std_xy_m = 10.0, location_std_z_m = 2.0;  // Gamma(c) (docs/method.md §13 #7)
  // Beyond the thesis (docs/method.md §4.2, §5.1): each class's detections
  // predicted as its silhouette (classes.yaml `shape:`) rather than the
  // cylinder's section; slice ends cut by the image's limits taken as bounds
  // (within censor_margin_px); the base height from the class's support
  // prior (classes.yaml `base_height_m`, `base_height_std_m`) instead of
  // location_std_z_m.
  bool silhouette_model = true;
  bool censor_slices = true;
  double censor_margin_px = 10.0;
  bool support_prior = true;
  // The bearing noise E_phi (SliceModel::bearing_noise_px; 0: E, the
  // thesis). The detector's bearings err by ~0.3 px and a symmetric
  // silhouette's middle is its base point's bearing; with E = 30 px on them
  // the map's heading rested on the first odometry steps (docs/method.md §4.2).
  // 10 px also covers the bearing error of blurred, compressed video.
  double bearing_noise_px = 10.0;
  // Detected classes are right: no switch moves, no merges across classes (Sec. 6.2).
  bool known_classes = false;
  // log P(a | c) counted once per track (default) or once per detection
  // (eq. 4.32 as printed). A track's detections are one object seen frame
  // after frame in the same light, so the detector's class decisions within
  // it are not independent draws; counting each one made the class term
  // outweigh the size prior and the geometry (long_loop: classes 8/11 ->
  // 10/11 per track; lab: 6/7 -> 7/7 and the door no longer mapped twice).
  bool class_likelihood_per_detection = false;

  // The sampler's options as run: with known_classes the switch moves'
  // share goes to merge and split, and classes never merge.
  SamplerOptions EffectiveSampler() const;
  bool Validate(std::string* why) const;
};

// Where the stage reads its input.
struct SlamStageInput {
  std::string run_dir;          // camera.yaml, classes.yaml, odometry.csv (and ground_truth/)
  std::string detections_path;  // read when `detections` is null; "" = run_dir/detections.csv
  // Detections already in memory (the detect stage's), used instead of the file.
  const std::vector<Detection>* detections = nullptr;
};

struct SlamStageResult {
  FusionResult fused;
  SamplerResult sampler;  // the baseline: its one solved state as the only sample
  OMapSource source;
  TrackSummary tracks;
  size_t num_tracks = 0;
  double seconds = 0;  // association and sampling
  // The sampler's run times (OMap::timing), which omap.json leaves out.
  std::vector<OMapReport> timing;
};

// Runs the stage and writes the O-Map to `output_json` (atomically). Throws
// oslam::Error naming the file and problem.
SlamStageResult RunSlamStage(const SlamStageInput& input, const std::string& output_json,
                             const SlamStageOptions& options, const StageOutput& output);

}  // namespace oslam
