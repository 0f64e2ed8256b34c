// The export stage: an O-Map as glTF (Blender), PLY (MeshLab), figures and
// optionally reprojection overlays on the run's frames.
#pragma once

#include <filesystem>
#include <string>

#include "export/export_scene.h"
#include "export/figures.h"
#include "omap/omap.h"
#include "pipeline/stage_output.h"

namespace oslam {

struct ExportStageOptions {
  double min_existence = 0.1;  // objects with a lower existence probability are left out
  int figure_size_px = 800;    // width and height of the figures
  bool floor_grid = true;      // a floor grid in the glTF
  int camera_every = 0;        // glTF: a camera pyramid at every Nth estimated pose, 0 = none
  bool ascii_ply = false;      // ASCII PLY instead of binary
  bool overlays = false;       // draw the map on the run's frames (overlays/NNNNNN.jpg)
  std::string overlay_frames;  // "" = every frame with an estimated pose; e.g. "0,10,20-30"
  std::string overlay_format = "jpg";  // "jpg" or "png" (lossless, slower)
  int threads = 2;                     // overlays drawn and written at once, 0 = one per core

  ExportOptions Models() const;   // glTF and PLY
  FigureOptions Figures() const;  // bird's-eye, perspective, trajectories
  bool Validate(std::string* why) const;
};

struct ExportStageInput {
  std::string run_dir;  // "" = none: no class colours, odometry or ground truth, no overlays
  // The detections drawn on the overlays; "" = run_dir/detections.csv if present.
  std::string detections_path;
};

// Writes into `out` (created) the files of docs/export.md: map.glb,
// map.gltf, map.ply, trajectory.ply, the TUM trajectories, the figures (PNG,
// SVG, CSV) and, with overlays, overlays/. Checks every input before writing anything;
// throws oslam::Error naming the file and problem (UsageError for a bad
// frame list).
void RunExportStage(const OMap& map, const ExportStageInput& input,
                    const std::filesystem::path& out, const ExportStageOptions& options,
                    const StageOutput& output);

}  // namespace oslam
