#include "export/display_scene.h"
#include "export/figures.h"
#include "export/vtk_view.h"

namespace oslam {

cv::Mat RenderPerspective(const ExportScene& scene, const FigureOptions& options) {
  ExportOptions models;
  models.min_existence = options.min_existence;
  models.cylinder_segments = options.cylinder_segments;
  ViewOptions view;
  view.width_px = options.width_px;
  view.height_px = options.height_px;
  view.azimuth_rad = options.view_azimuth_rad;
  view.elevation_rad = options.view_elevation_rad;
  view.min_existence = options.min_existence;
  return RenderView(scene, BuildDisplayScene(scene, models), view);
}

}  // namespace oslam
