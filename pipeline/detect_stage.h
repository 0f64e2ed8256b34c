// The detect stage: colour-blob detections (bounding slices) in every frame
// of a run folder, optionally verified by SIFT, written as CSV.
#pragma once

#include <string>
#include <vector>

#include "detect/blob_detector.h"
#include "pipeline/stage_output.h"

namespace oslam {

struct DetectStageOptions {
  BlobDetectorOptions detector;
  std::string sift_templates;    // templates.yaml for SIFT verification; "" = colour only
  int threads = 2;               // frames decoded and searched at once, 0 = one per core
  bool skip_bad_frames = false;  // warn about unreadable frames and go on
  std::string debug_images_dir;  // "" = none; else each frame with its slices drawn
  // Static mask image (detect/static_mask.h: 0 = ignored): "" = RUN/mask.png
  // when the run has one, "none" = no mask, else this file.
  std::string mask;

  bool Validate(std::string* why) const;
};

struct DetectStageResult {
  std::vector<Detection> detections;  // in frame order
  size_t frames = 0;
  size_t skipped_frames = 0;  // unreadable (skip_bad_frames)
  size_t sift_rejected = 0;
};

// Detects in every frame of `run_dir` (frames, camera.yaml, classes.yaml
// with colour models) and writes the detections to `output_csv`
// (atomically). The result does not depend on the threads. Throws
// oslam::Error naming the file and problem.
DetectStageResult RunDetectStage(const std::string& run_dir, const std::string& output_csv,
                                 const DetectStageOptions& options, const StageOutput& output);

}  // namespace oslam
