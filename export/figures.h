// Figures of an O-Map for papers and reports, drawn with PLplot (cairo):
// each as a PNG, the same drawing as SVG, and the plotted data as CSV.
//  - bird's-eye view (thesis figs. 6.3b, 6.10): objects as discs of their
//    diameter in class colour with opacity = pi, base points, labels that
//    avoid each other, the trajectories; metric axes and a legend of every
//    mark;
//  - trajectory errors (figs. 6.4a, 6.18a as errors): horizontal position
//    error per frame of the estimate and of odometry against ground truth;
//  - any line plot (the sampler's trace in the report);
//  - perspective view (figs. 6.3a, 6.7a): the 3D scene rendered off-screen by
//    VTK (export/vtk_view.h); PNG only.
// Text and line widths scale with the figure size.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
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

struct Figure {
  cv::Mat image;    // BGR 8-bit, width_px x height_px
  std::string svg;  // the same drawing
  std::string csv;  // the data drawn
  // The plot's window in data units (x_min, x_max, y_min, y_max) and where
  // it lies in the image (pixels, y down).
  Eigen::Vector4d window = Eigen::Vector4d::Zero();
  cv::Rect2d viewport_px;
  cv::Point2d PixelOf(double x, double y) const;
};

Figure BirdsEyeFigure(const ExportScene& scene, const FigureOptions& options);
// Throws oslam::Error when the scene has no ground truth to compare with.
Figure TrajectoryErrorFigure(const ExportScene& scene, const FigureOptions& options);

struct PlotSeries {
  std::string name;    // legend text
  std::string column;  // CSV column
  std::vector<double> x, y;
  Rgb rgb{};
  bool dashed = false;
};

// Lines on metric axes with a legend; the CSV has x and one column per
// series (rows by x, empty where a series has no value).
Figure LinePlotFigure(const std::string& title, const std::string& x_label,
                      const std::string& y_label, const std::vector<PlotSeries>& series,
                      const FigureOptions& options);

cv::Mat RenderPerspective(const ExportScene& scene, const FigureOptions& options);

// The PNG bytes of a BGR image; `fast`: a quicker, larger compression (the
// overlays, many at a time). Throws oslam::Error on failure.
std::string EncodePng(const cv::Mat& image, bool fast = false);

// Writes a PNG atomically (core/atomic_file.h); throws oslam::Error naming
// the file on failure.
void WritePng(const cv::Mat& image, const std::string& path, FileSync sync = FileSync::kEach);

}  // namespace oslam
