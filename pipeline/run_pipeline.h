// `oslam run` as a library: one call from a video folder to an O-Map. The
// stages (detect, O-SLAM, export) run in turn with typed options, then the
// map is evaluated against ground truth when the folder has it, and a short
// report is written.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "omap/evaluation.h"
#include "omap/omap.h"
#include "pipeline/detect_stage.h"
#include "pipeline/eval_stage.h"
#include "pipeline/export_stage.h"
#include "pipeline/slam_stage.h"
#include "pipeline/stage_output.h"

namespace oslam {

struct RunPipelineOptions {
  // A run draws the map on every frame; `oslam export` alone only when asked.
  RunPipelineOptions() { export_.overlays = true; }

  DetectStageOptions detect;
  SlamStageOptions slam;
  ExportStageOptions export_;  // `export` is a keyword
  EvalStageOptions eval;

  // Reuse the stages that the last run into the same output folder
  // completed with the same `settings` on the same inputs (run.json);
  // without it, or when nothing matches, every stage runs afresh.
  bool resume = false;
  // The configuration's text (config.yaml), part of run.json's fingerprint.
  std::string settings;

  // Every stage's options, checked before anything runs.
  bool Validate(std::string* why) const;
};

struct StageTime {
  std::string name;  // detect, o-slam, export
  double seconds = 0;
  // CPU time of all the process' threads: next to the wall time it shows
  // how parallel a stage ran, and on a shared machine it is the steadier
  // measure.
  double cpu_seconds = 0;
};

struct RunPipelineResult {
  std::string detections_path, omap_path, report_path;
  std::string eval_path;  // "" without ground truth
  DetectStageResult detect;
  SlamStageResult slam;
  OMap map;                           // as written to omap_path
  std::optional<MapMetrics> metrics;  // with ground truth
  std::vector<StageTime> times;       // one per stage, in order

  StageTime Total() const;  // name "total"
};

struct RunPipelineCallbacks {
  // Once the inputs are checked and the output folder exists, before any
  // stage runs (e.g. to write the configuration there).
  std::function<void()> ready;
  // As each stage starts: ("detect", 1, 3), ("o-slam", 2, 3), ("export", 3, 3).
  std::function<void(const std::string& stage, int index, int count)> stage_started;
  StageOutput output;  // the stages' progress, report lines and warnings
};

// What every run needs, checked before anything is written: frames,
// odometry.csv with one row per frame, camera.yaml, classes.yaml with a
// colour model. Throws oslam::Error naming the file and problem.
void CheckRunInputs(const std::string& run_dir);

// Writes into `out_dir` (created): detections.csv, omap.json, the export's
// files, eval.json (with ground truth) and report.md, and run.json, the
// folder's status (pipeline/run_status.h): running from the start, then
// complete, or failed with the error. A re-run first removes the files it
// writes, so no older result is left beside the new ones. Throws
// oslam::Error (invalid options, bad input: before anything is written).
RunPipelineResult RunPipeline(const std::string& run_dir, const std::string& out_dir,
                              const RunPipelineOptions& options,
                              const RunPipelineCallbacks& callbacks = {});

}  // namespace oslam
