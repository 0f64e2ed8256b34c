// report.md of `oslam run`, written to be read: what went in (frames,
// detections, tracks, version, configuration), how long each stage took,
// the objects (and which the 3D files leave out), the sampler's convergence
// as a trace plot with its effective sample size and acceptance rates, and
// the scores, each under one name with its definition (horizontal or 3D).
#pragma once

#include <string>

#include "pipeline/run_pipeline.h"

namespace oslam {

// The report's text; `trace_figure` names the trace plot it links ("" =
// none).
std::string RunReport(const std::string& run_dir, const RunPipelineOptions& options,
                      const RunPipelineResult& result, const std::string& trace_figure);

// The sampler's trace as sampler_trace.{png,svg,csv} in `out_dir`: the log
// target of hill climbing (steps <= 0) and of the MC³ cold chain
// (iterations >= 1), relative to the hill-climbed state. Returns the PNG's
// name, or "" when the run has no trace (the nearest-neighbour baseline).
std::string WriteSamplerTrace(const SamplerSummary& sampler, const std::string& out_dir);

// One line of the input for the terminal: "150 frames, 812 detections, 41 tracks".
std::string InputSummary(const RunPipelineResult& result);

}  // namespace oslam
