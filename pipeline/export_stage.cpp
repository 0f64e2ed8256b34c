#include "pipeline/export_stage.h"

#include <optional>

#include "core/error.h"
#include "export/export_files.h"

namespace oslam {
namespace {

ExportOptions ModelOptions(const ExportStageOptions& options) {
  ExportOptions models;
  models.min_existence = options.min_existence;
  models.floor_grid = options.floor_grid;
  return models;
}

FigureOptions Figures(const ExportStageOptions& options) {
  FigureOptions figures;
  figures.min_existence = options.min_existence;
  figures.width_px = figures.height_px = options.figure_size_px;
  return figures;
}

}  // namespace

bool ExportStageOptions::Validate(std::string* why) const {
  if (!ModelOptions(*this).Validate(why) || !Figures(*this).Validate(why)) return false;
  if (threads < 0) {
    if (why) *why = "the overlay threads must be >= 0 (0 = one per core)";
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
  if (options.overlays)
    overlays = PrepareOverlays(scene, input.run_dir, options.overlay_frames, input.detections_path);
  CreateOutputFolder(out);

  WriteModels(scene, ModelOptions(options), out, options.ascii_ply, output.quiet);
  WriteFigures(scene, Figures(options), out, output.quiet);
  if (overlays)
    WriteOverlays(scene, *overlays, options.min_existence, out / "overlays", output.quiet,
                  options.threads);
  output.Print("wrote " + out.string());
}

}  // namespace oslam
