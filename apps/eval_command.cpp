// oslam eval: an O-Map against the simulator's ground truth
// (pipeline/eval_stage.h).
#include <cstdio>
#include <filesystem>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "apps/stage_bindings.h"
#include "core/error.h"
#include "omap/omap_json.h"

namespace oslam {

int RunEvalCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam eval OMAP.json RUN_DIR/ground_truth [--json] [-o METRICS.json]",
                      "Scores an O-Map against ground truth: ATE and RPE of the estimate and of "
                      "raw odometry,\nobjects matched one to one (Hungarian, distance gate) with "
                      "position, size and class errors,\ntrue objects found and spurious objects "
                      "above an existence threshold.");
  arguments.AddPositional("OMAP.json", "the O-Map (oslam run / oslam slam)");
  arguments.AddPositional("GROUND_TRUTH",
                          "the run's ground_truth/ folder (its parent holds odometry.csv)");
  EvalStageOptions options;
  Bindings bindings;
  BindEvalOptions(&options, &bindings);
  bindings.Declare(&arguments);
  arguments.AddFlag("json", "print JSON instead of the table");
  arguments.AddOption("output", "-o", "FILE", "also write the JSON here (atomically)");
  if (!arguments.Parse(args)) return 0;
  bindings.Apply(arguments);
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);

  std::filesystem::path truth_dir(arguments.Get("GROUND_TRUTH"));
  if (truth_dir.filename().empty()) truth_dir = truth_dir.parent_path();  // trailing slash
  const std::string run_dir = truth_dir.parent_path().string();
  if (!std::filesystem::is_directory(truth_dir))
    throw Error::InFile(truth_dir.string(), "ground-truth folder not found");
  const auto metrics =
      RunEvalStage(ReadOMap(arguments.Get("OMAP.json")), run_dir.empty() ? "." : run_dir,
                   arguments.Get("output"), options);
  if (!metrics) throw Error::InFile(truth_dir.string(), "ground-truth folder not found");
  std::fputs(arguments.Flag("json") ? metrics->Json().c_str() : metrics->Table().c_str(), stdout);
  return 0;
}

}  // namespace oslam
