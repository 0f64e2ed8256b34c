#include "pipeline/export_stage.h"

#include <optional>

#include "core/atomic_file.h"
#include "core/error.h"
#include "export/export_files.h"

namespace oslam {

ExportOptions ExportStageOptions::Models() const {
  ExportOptions models;
  models.min_existence = min_existence;
  models.floor_grid = floor_grid;
  models.camera_every = camera_every;
  return models;
}

FigureOptions ExportStageOptions::Figures() const {
  FigureOptions figures;
  figures.min_existence = min_existence;
  figures.width_px = figures.height_px = figure_size_px;
  return figures;
}

bool ExportStageOptions::Validate(std::string* why) const {
  if (!Models().Validate(why) || !Figures().Validate(why)) return false;
  if (threads < 0) {
    if (why) *why = "the overlay threads must be >= 0 (0 = one per core)";
    return false;
  }
  if (!ParseOverlayFormat(overlay_format)) {
    if (why) *why = "the overlay format must be jpg or png, not '" + overlay_format + "'";
    return false;
  }
  return true;
}

void RunExportStage(const OMap& map, const ExportStageInput& input,
                    const std::filesystem::path& out, const ExportStageOptions& options,
                    const StageOutput& output) {
  std::string why;
  if (!options.Validate(&why)) throw Error("export: " + why);
  if (options.overlays && input.run_dir.empty())
    throw Error("export: the overlays need the run folder (frames and camera)");
  ExportScene scene;
  scene.map = map;
  if (!input.run_dir.empty()) ReadRunContext(input.run_dir, &scene);
  std::optional<OverlayInput> overlays;
  if (options.overlays) {
    overlays = PrepareOverlays(scene, input.run_dir, options.overlay_frames, input.detections_path);
    CheckOutputSubfolder(out.string(), "overlays");
  }
  CreateOutputFolder(out);

  WriteExportFiles(scene, options.Models(), options.ascii_ply, options.Figures(),
                   overlays ? &*overlays : nullptr, *ParseOverlayFormat(options.overlay_format),
                   out, output.quiet, options.threads);
  output.Print("wrote " + out.string());
}

}  // namespace oslam
