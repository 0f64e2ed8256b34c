#include "pipeline/eval_stage.h"

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"

namespace oslam {

std::optional<MapMetrics> RunEvalStage(const OMap& map, const std::string& run_dir,
                                       const std::string& output_json,
                                       const EvalStageOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("eval: " + why);
  const std::optional<GroundTruth> truth = ReadGroundTruth(run_dir);
  if (!truth) return std::nullopt;
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  const Odometry odometry = ReadOdometry(paths.odometry);
  // Either file may be the short one: name both.
  if (odometry.poses.size() != truth->trajectory.size())
    throw Error::InFile(paths.ground_truth + "/trajectory.csv",
                        "has " + std::to_string(truth->trajectory.size()) + " rows but " +
                            paths.odometry + " has " + std::to_string(odometry.poses.size()));
  const MapMetrics metrics = EvaluateMap(map, odometry.poses, *truth, options.metrics);
  if (!output_json.empty()) WriteTextFileAtomically(output_json, metrics.Json());
  return metrics;
}

}  // namespace oslam
