// oslam eval: an O-Map against the simulator's ground truth.
#include <cstdio>
#include <filesystem>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "omap/evaluation.h"
#include "omap/omap_json.h"

namespace oslam {

int RunEvalCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam eval OMAP.json RUN_DIR/ground_truth [--json] [-o METRICS.json]",
                      "Scores an O-Map against ground truth: ATE and RPE of the estimate and of "
                      "raw odometry,\nobjects matched one to one (Hungarian, distance gate) with "
                      "position, size and class errors,\ntrue objects found and spurious objects "
                      "above an existence threshold.");
  arguments.AddPositional("OMAP.json", "the O-Map (oslam run / oslam slam)");
  arguments.AddPositional("GROUND_TRUTH", "the run's ground_truth/ folder (its parent holds odometry.csv)");
  arguments.AddOption("threshold", "", "P", "objects with existence probability <= P are left out", "0.5");
  arguments.AddOption("gate", "", "M", "largest horizontal base-point distance of a match", "0.5");
  arguments.AddFlag("json", "print JSON instead of the table");
  arguments.AddOption("output", "-o", "FILE", "also write the JSON here (atomically)");
  if (!arguments.Parse(args)) return 0;
  MapMetricsOptions options;
  options.existence_threshold = arguments.GetDouble("threshold");
  options.match_gate_m = arguments.GetDouble("gate");
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);

  std::filesystem::path truth_dir(arguments.Get("GROUND_TRUTH"));
  if (truth_dir.filename().empty()) truth_dir = truth_dir.parent_path();  // trailing slash
  const std::string run_dir = truth_dir.parent_path().string();
  if (!std::filesystem::is_directory(truth_dir))
    throw Error::InFile(truth_dir.string(), "ground-truth folder not found");
  const std::optional<GroundTruth> truth = ReadGroundTruth(run_dir.empty() ? "." : run_dir);
  if (!truth) throw Error::InFile(truth_dir.string(), "ground-truth folder not found");
  const OMap map = ReadOMap(arguments.Get("OMAP.json"));
  const Odometry odometry =
      ReadOdometry(RunFolderPaths::Of(run_dir.empty() ? "." : run_dir).odometry,
                   static_cast<long>(truth->trajectory.size()));
  const MapMetrics metrics = EvaluateMap(map, odometry.poses, *truth, options);
  std::fputs(arguments.Flag("json") ? metrics.Json().c_str() : metrics.Table().c_str(), stdout);
  if (arguments.Has("output")) WriteTextFileAtomically(arguments.Get("output"), metrics.Json());
  return 0;
}

}  // namespace oslam
