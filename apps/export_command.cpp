// oslam export: an O-Map as glTF (Blender), PLY (MeshLab), figures and
// optional reprojection overlays on the run's frames (pipeline/export_stage.h).
#include "apps/arguments.h"
#include "apps/commands.h"
#include "apps/stage_bindings.h"
#include "core/error.h"
#include "omap/omap_json.h"

namespace oslam {

int RunExportCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam export OMAP.json -o OUT_DIR [--run RUN_DIR] [options]",
      "Writes an O-Map as map.glb and map.gltf (glTF 2.0 scene, Y up, for Blender), map.ply\n"
      "and trajectory.ply (for MeshLab), trajectory_*.txt (TUM format, for evo), and the\n"
      "figures birdseye and trajectories (PNG, SVG, CSV) and perspective.png (docs/export.md).\n"
      "RUN_DIR supplies class colours and shapes, odometry, ground truth, and for --overlays\n"
      "the frames, camera and detections.");
  arguments.AddPositional("OMAP", "the O-Map JSON (oslam map)");
  arguments.AddOption("output", "-o", "DIR", "output folder (created)");
  ExportStageInput input;
  ExportStageOptions options;
  Bindings bindings;
  bindings.Add(&input.run_dir, "run", "RUN_DIR", "the run folder the map was made from");
  BindExportOptions(&options, &bindings);
  bindings.Add(&input.detections_path, "detections", "FILE", "detections drawn on the overlays")
      .ShowDefault("RUN_DIR/detections.csv if present");
  bindings.Declare(&arguments);
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o OUT_DIR");
  bindings.Apply(arguments);
  if (options.overlays && input.run_dir.empty())
    throw UsageError("--overlays needs --run RUN_DIR (frames and camera)");
  if ((arguments.Has("frames") || arguments.Has("detections")) && !options.overlays)
    throw UsageError("--frames and --detections apply to --overlays only");
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);

  RunExportStage(ReadOMap(arguments.Get("OMAP")), input, arguments.Get("output"), options,
                 CommandOutput("export", arguments.Flag("quiet")));
  return 0;
}

}  // namespace oslam
