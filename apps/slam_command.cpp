// oslam slam: O-SLAM on a run folder's detections (pipeline/slam_stage.h);
// also the mode of `oslam map` without --known-association or --landmarks.
#include "apps/commands.h"
#include "apps/map_modes.h"
#include "apps/stage_bindings.h"
#include "core/error.h"

namespace oslam {

void SlamMode::Declare(Arguments* arguments) {
  arguments->AddPositional("RUN_DIR", "run folder (camera.yaml, classes.yaml, odometry.csv)");
  bindings_.Add(&input_.detections_path, "detections", "FILE",
                "detections CSV (default RUN_DIR/detections.csv)");
  BindSlamOptions(&options_, &bindings_);
  bindings_.Declare(arguments);
}

int SlamMode::Run(const Arguments& arguments) {
  if (!arguments.Has("output")) throw UsageError("give the output file with -o OMAP.json");
  bindings_.Apply(arguments);
  std::string why;
  if (!options_.Validate(&why)) throw UsageError(why);
  input_.run_dir = arguments.Get("RUN_DIR");
  RunSlamStage(input_, arguments.Get("output"), options_,
               CommandOutput("slam", arguments.Flag("quiet")));
  return 0;
}

int RunSlamCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam slam RUN_DIR -o OMAP.json [options]",
                      "O-SLAM: data association and classes by hill climbing and MC3 over the "
                      "detections' tracks; writes the O-Map with existence probabilities.");
  arguments.AddOption("output", "-o", "OMAP.json", "where to write the O-Map (atomically)");
  SlamMode mode;
  mode.Declare(&arguments);
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  return mode.Run(arguments);
}

}  // namespace oslam
