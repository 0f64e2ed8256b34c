// oslam detect: colour-blob detections (bounding slices) for every frame of a
// run folder (pipeline/detect_stage.h).
#include "apps/arguments.h"
#include "apps/commands.h"
#include "apps/stage_bindings.h"
#include "core/error.h"
#include "core/run_folder.h"

namespace oslam {

int RunDetectCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam detect RUN_DIR [-o detections.csv] [options]",
                      "Detects objects by colour in every frame of RUN_DIR and writes their "
                      "bounding slices as CSV.\nNeeds camera.yaml and classes.yaml with colour "
                      "models (see 'oslam train-colors').");
  arguments.AddPositional("RUN_DIR", "the run folder, or a video file in it (docs/formats.md)");
  arguments.AddOption("output", "-o", "FILE", "detections CSV", "RUN_DIR/detections.csv");
  DetectStageOptions options;
  Bindings bindings;
  BindDetectOptions(&options, &bindings);
  bindings.Declare(&arguments);
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  bindings.Apply(arguments);
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);

  const std::string run_dir = arguments.Get("RUN_DIR");
  const std::string output =
      arguments.Has("output") ? arguments.Get("output") : RunFolderPaths::Of(run_dir).detections;
  RunDetectStage(run_dir, output, options, CommandOutput("detect", arguments.Flag("quiet")));
  return 0;
}

}  // namespace oslam
