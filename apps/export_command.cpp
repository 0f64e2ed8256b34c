// oslam export: an O-Map as glTF (Blender), PLY (MeshLab), figures and
// optional reprojection overlays on the run's frames.
#include <cstdio>
#include <filesystem>
#include <optional>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "core/error.h"
#include "export/export_files.h"
#include "omap/omap_json.h"

namespace oslam {

int RunExportCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam export OMAP.json -o OUT_DIR [--run RUN_DIR] [options]",
      "Writes an O-Map as map.glb and map.gltf (glTF 2.0, Y up, for Blender), map.ply and\n"
      "trajectory.ply (for MeshLab), and birdseye.png, perspective.png, trajectories.png.\n"
      "RUN_DIR supplies class colours, odometry, ground truth, and for --overlays the frames,\n"
      "camera and detections.");
  arguments.AddPositional("OMAP", "the O-Map JSON (oslam map)");
  arguments.AddOption("output", "-o", "DIR", "output folder (created)");
  arguments.AddOption("run", "", "RUN_DIR", "the run folder the map was made from");
  arguments.AddOption("min-existence", "", "P", "leave out objects with existence probability < P",
                      "0.1");
  arguments.AddOption("figure-size", "", "PX", "width and height of the figures", "800");
  arguments.AddFlag("no-grid", "no floor grid in the glTF");
  arguments.AddFlag("ascii-ply", "write ASCII PLY instead of binary");
  arguments.AddFlag("overlays", "also draw the map on the run's frames (overlays/NNNNNN.jpg)");
  arguments.AddOption("frames", "", "LIST", "overlay only these frames, e.g. 0,10,20-30");
  arguments.AddOption("detections", "", "FILE", "detections drawn on the overlays",
                      "RUN_DIR/detections.csv if present");
  arguments.AddOption("threads", "", "N", "overlays drawn and written at once (0 = one per core)",
                      "2");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o OUT_DIR");
  if (arguments.Flag("overlays") && !arguments.Has("run"))
    throw UsageError("--overlays needs --run RUN_DIR (frames and camera)");
  if ((arguments.Has("frames") || arguments.Has("detections")) && !arguments.Flag("overlays"))
    throw UsageError("--frames and --detections apply to --overlays only");

  ExportOptions options;
  options.min_existence = arguments.GetDouble("min-existence");
  options.floor_grid = !arguments.Flag("no-grid");
  FigureOptions figures;
  figures.min_existence = options.min_existence;
  figures.width_px = figures.height_px = static_cast<int>(arguments.GetInt("figure-size"));
  std::string why;
  if (!options.Validate(&why) || !figures.Validate(&why)) throw UsageError(why);
  const bool quiet = arguments.Flag("quiet");
  const long threads = arguments.GetInt("threads");
  if (threads < 0) throw UsageError("--threads must be >= 0");

  ExportScene scene;
  scene.map = ReadOMap(arguments.Get("OMAP"));
  if (arguments.Has("run")) ReadRunContext(arguments.Get("run"), &scene);
  std::optional<OverlayInput> overlays;
  if (arguments.Flag("overlays"))
    overlays = PrepareOverlays(scene, arguments.Get("run"), arguments.Get("frames"),
                               arguments.Has("detections") ? arguments.Get("detections") : "");
  const std::filesystem::path out = arguments.Get("output");
  CreateOutputFolder(out);

  WriteExportFiles(scene, options, arguments.Flag("ascii-ply"), figures,
                   overlays ? &*overlays : nullptr, OverlayFormat::kJpeg, out, quiet,
                   static_cast<int>(threads));
  if (!quiet) std::printf("wrote %s\n", out.string().c_str());
  return 0;
}

}  // namespace oslam
