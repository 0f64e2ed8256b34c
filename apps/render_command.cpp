// oslam render: figures of an O-Map (bird's-eye view, perspective view and,
// with a run's ground truth, the trajectory comparison plot); the drawing is
// in export/figures.h.
#include <cstdio>

#include "apps/arguments.h"
#include "apps/bindings.h"
#include "apps/commands.h"
#include "core/error.h"
#include "export/export_files.h"
#include "omap/omap_json.h"
#include "pipeline/export_stage.h"

namespace oslam {

int RunRenderCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam render OMAP.json -o OUT_DIR [--run RUN_DIR] [options]",
      "Writes birdseye.{png,svg,csv} and perspective.png, and trajectories.{png,svg,csv} when\n"
      "RUN_DIR has ground truth. RUN_DIR also supplies class colours and shapes, and odometry.");
  arguments.AddPositional("OMAP", "the O-Map JSON (oslam map)");
  arguments.AddOption("output", "-o", "DIR", "output folder (created)");
  arguments.AddOption("run", "", "RUN_DIR", "the run folder the map was made from");
  // The export stage's figure options, with its defaults.
  ExportStageOptions options;
  Bindings bindings;
  bindings.Add(&options.min_existence, "min-existence", "P",
               "leave out objects with existence probability < P");
  bindings.Add(&options.figure_size_px, "figure-size", "PX", "width and height of the figures");
  bindings.Declare(&arguments);
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o OUT_DIR");
  bindings.Apply(arguments);
  const FigureOptions figures = options.Figures();
  std::string why;
  if (!figures.Validate(&why)) throw UsageError(why);
  const bool quiet = arguments.Flag("quiet");

  ExportScene scene;
  scene.map = ReadOMap(arguments.Get("OMAP"));
  if (arguments.Has("run")) ReadRunContext(arguments.Get("run"), &scene);
  const std::string out = arguments.Get("output");
  CreateOutputFolder(out);
  const std::vector<std::string> written = WriteFigures(scene, figures, out, quiet);
  if (!quiet) std::printf("wrote %zu figures to %s\n", written.size(), out.c_str());
  return 0;
}

}  // namespace oslam
