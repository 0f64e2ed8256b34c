// The O-Map in 3D with VTK: objects in their class shapes with opacity = pi
// and labels that avoid each other, the trajectories as tubes, the floor with
// a metric grid and axis values, a legend, and optionally the frame of one
// estimated pose. One scene, two outlets:
//  - RenderView: off-screen, through Mesa's EGL (no X display needed), into
//    an image: perspective.png and `oslam view --screenshot`;
//  - ShowView: an interactive window (`oslam view`), which needs a display.
// VTK headers stay in export/vtk_view.cpp.
#pragma once

#include <opencv2/core/mat.hpp>

#include "export/display_scene.h"
#include "export/export_scene.h"

namespace oslam {

struct ViewOptions {
  int width_px = 800;
  int height_px = 600;
  // The camera looks at the map from this compass direction (radians,
  // counter-clockwise from +x) and elevation above the floor, placed so the
  // map fills the image.
  double azimuth_rad = -2.2;
  double elevation_rad = 0.6;
  // Estimated pose drawn as its frame (x forward red, y left green, z up
  // blue); -1: none.
  long selected_pose = -1;
  // Objects with a lower pi were left out of the display scene (for the legend).
  double min_existence = 0.1;
  bool Validate(std::string* why) const;
};

// Renders `display` (built from `scene`) off-screen; BGR 8-bit,
// width_px x height_px. Throws oslam::Error when no off-screen OpenGL
// context can be made (no EGL driver).
cv::Mat RenderView(const ExportScene& scene, const DisplayScene& display,
                   const ViewOptions& options);

// Opens a window showing the same scene; mouse: rotate, pan, zoom (VTK's
// trackball camera); Left/Right: previous/next estimated pose; Q closes it.
// Returns when the window is closed. Throws oslam::Error without a display.
void ShowView(const ExportScene& scene, const DisplayScene& display, const ViewOptions& options);

}  // namespace oslam
