// oslam overlay: the O-Map reprojected onto a run's frames (thesis figs. 6.4b,
// 6.11), one PNG per frame; the drawing is in export/overlay.h.
#include <cstdio>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "core/error.h"
#include "export/export_files.h"
#include "omap/omap_json.h"

namespace oslam {

int RunOverlayCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam overlay RUN_DIR OMAP.json -o OUT_DIR [--frames LIST] [options]",
      "Draws every map object's projected bounding slice (class colour, faded by its existence\n"
      "probability, labelled) and the frame's detections on the run's frames: OUT_DIR/NNNNNN.jpg.");
  arguments.AddPositional("RUN_DIR", "the run folder the map was made from (frames, camera)");
  arguments.AddPositional("OMAP", "the O-Map JSON (oslam map)");
  arguments.AddOption("output", "-o", "DIR", "output folder (created)");
  arguments.AddOption("frames", "", "LIST", "only these frames, e.g. 0,10,20-30 (default: all)");
  arguments.AddOption("min-existence", "", "P", "leave out objects with existence probability < P",
                      "0.1");
  arguments.AddOption("threads", "", "N", "overlays drawn and written at once (0 = one per core)",
                      "2");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o OUT_DIR");
  ExportOptions options;
  options.min_existence = arguments.GetDouble("min-existence");
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);
  const bool quiet = arguments.Flag("quiet");
  const long threads = arguments.GetInt("threads");
  if (threads < 0) throw UsageError("--threads must be >= 0");

  ExportScene scene;
  scene.map = ReadOMap(arguments.Get("OMAP"));
  ReadRunContext(arguments.Get("RUN_DIR"), &scene);
  const OverlayInput input =
      PrepareOverlays(scene, arguments.Get("RUN_DIR"), arguments.Get("frames"));
  const std::string out = arguments.Get("output");
  WriteOverlays(scene, input, options.min_existence, out, quiet, static_cast<int>(threads));
  if (!quiet) std::printf("wrote %zu overlays to %s\n", input.chosen.size(), out.c_str());
  return 0;
}

}  // namespace oslam
