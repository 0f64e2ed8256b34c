// The eval stage: an O-Map against a simulated run's ground truth (ATE and
// RPE of the estimate and of raw odometry, objects matched one to one).
#pragma once

#include <optional>
#include <string>

#include "omap/evaluation.h"
#include "omap/omap.h"

namespace oslam {

struct EvalStageOptions {
  MapMetricsOptions metrics;  // existence threshold, match gate

  bool Validate(std::string* why) const { return metrics.Validate(why); }
};

// Scores `map` against `run_dir`'s ground_truth/ and odometry.csv and, when
// `output_json` is not "", writes the scores there (atomically). No ground
// truth: std::nullopt and nothing written. Throws oslam::Error naming the
// file and problem.
std::optional<MapMetrics> RunEvalStage(const OMap& map, const std::string& run_dir,
                                       const std::string& output_json,
                                       const EvalStageOptions& options);

}  // namespace oslam
