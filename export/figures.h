// Figures of an O-Map as PNG-ready BGR images (OpenCV drawing only, so they
// are deterministic and golden-testable):
//  - bird's-eye view (thesis figs. 6.3b, 6.10): objects as discs in class
//    colour with opacity pi, class labels, trajectories, metric grid, scale;
//  - perspective view (figs. 6.3a, 6.7a): the cylinders on a floor grid, by a
//    small painter's-algorithm rasteriser (Debian's VTK 9.1 renders only
//    through an X display, see docs/export.md);
//  - trajectory comparison (figs. 6.4a, 6.18a as errors): position error per
//    frame of the estimate and of odometry against ground truth.
#pragma once

#include <opencv2/core/mat.hpp>

#include "core/atomic_file.h"
#include "export/export_scene.h"

namespace oslam {

struct FigureOptions {
  int width_px = 800;
  int height_px = 800;
  double min_existence = 0.1;  // the thesis' figures hide objects with pi < 0.1
  int cylinder_segments = 32;
  // Perspective camera: looking at the map centre from this compass direction
  // (radians, counter-clockwise from +x) and elevation above the floor.
  double view_azimuth_rad = -2.2;
  double view_elevation_rad = 0.6;
  bool Validate(std::string* why) const;
};

cv::Mat RenderBirdsEye(const ExportScene& scene, const FigureOptions& options);
cv::Mat RenderPerspective(const ExportScene& scene, const FigureOptions& options);
// Throws oslam::Error when the scene has no ground truth to compare with.
cv::Mat PlotTrajectoryErrors(const ExportScene& scene, const FigureOptions& options);

// Writes a PNG atomically (core/atomic_file.h); throws oslam::Error naming
// the file on failure.
void WritePng(const cv::Mat& image, const std::string& path, FileSync sync = FileSync::kEach);

}  // namespace oslam
