// A run whose odometry is logged by time (docs/formats.md, "Odometry by
// time") turned into an ordinary run folder: the frames kept by the frame
// selection (core/odometry_sync.h), each with its interpolated odometry
// pose, so the stages see one odometry row per frame.
#pragma once

#include <string>

#include "core/odometry_sync.h"
#include "pipeline/stage_output.h"

namespace oslam {

struct TimedRunResult {
  std::string run_dir;  // the run folder written
  FrameSelection selection;
};

// Writes `out_run_dir` (created; must not hold a run): frames/ (the kept
// frames as PNG), odometry.csv (one pose per kept frame), frame_times.csv,
// frames.csv (kept frame -> source frame, time, pose), camera.yaml,
// classes.yaml and mask.png when present (copied) and, when the source has ground truth, its
// trajectory and sightings of the kept frames. Throws oslam::Error naming the
// file when the frames have no times or the odometry is not by time.
TimedRunResult PrepareTimedRun(const std::string& run_or_video, const std::string& out_run_dir,
                               const FrameSelectionOptions& options, const StageOutput& output);

}  // namespace oslam
