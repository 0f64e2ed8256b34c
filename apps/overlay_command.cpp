// oslam overlay: the O-Map reprojected onto a run's frames (thesis figs. 6.4b,
// 6.11), one image per frame; the drawing is in export/overlay.h.
#include <cstdio>

#include "apps/arguments.h"
#include "apps/bindings.h"
#include "apps/commands.h"
#include "core/error.h"
#include "export/export_files.h"
#include "omap/omap_json.h"
#include "pipeline/export_stage.h"

namespace oslam {

int RunOverlayCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam overlay RUN_DIR OMAP.json -o OUT_DIR [--frames LIST] [options]",
      "Draws every map object's projected bounding slice (class colour, faded by its existence\n"
      "probability, labelled) and the frame's detections on the run's frames: OUT_DIR/NNNNNN.jpg.");
  arguments.AddPositional("RUN_DIR", "the run folder the map was made from (frames, camera)");
  arguments.AddPositional("OMAP", "the O-Map JSON (oslam map)");
  arguments.AddOption("output", "-o", "DIR", "output folder (created)");
  // The export stage's overlay options, with its defaults.
  ExportStageOptions options;
  Bindings bindings;
  bindings.Add(&options.overlay_frames, "frames", "LIST",
               "only these frames, e.g. 0,10,20-30 (default: all)");
  bindings.Add(&options.min_existence, "min-existence", "P",
               "leave out objects with existence probability < P");
  bindings
      .Add(&options.overlay_format, "format", "jpg|png",
           "image format (png: lossless, about 3x slower)")
      .Check([&options] { return ParseOverlayFormat(options.overlay_format).has_value(); },
             "must be jpg or png");
  bindings
      .Add(&options.threads, "threads", "N",
           "overlays drawn and written at once (0 = one per core)")
      .Check([&options] { return options.threads >= 0; }, "must be >= 0");
  bindings.Declare(&arguments);
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o OUT_DIR");
  bindings.Apply(arguments);
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);
  const bool quiet = arguments.Flag("quiet");

  ExportScene scene;
  scene.map = ReadOMap(arguments.Get("OMAP"));
  ReadRunContext(arguments.Get("RUN_DIR"), &scene);
  const OverlayInput input =
      PrepareOverlays(scene, arguments.Get("RUN_DIR"), options.overlay_frames);
  const std::string out = arguments.Get("output");
  WriteOverlays(scene, input, options.min_existence, out, quiet, options.threads,
                *ParseOverlayFormat(options.overlay_format));
  if (!quiet) std::printf("wrote %zu overlays to %s\n", input.chosen.size(), out.c_str());
  return 0;
}

}  // namespace oslam
