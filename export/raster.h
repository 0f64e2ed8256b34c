// Small OpenCV drawing helpers shared by the overlays and figures: colour
// conversion, alpha-blended shapes (opacity = existence probability, docs/method.md §2)
// and readable labels. Deterministic, so figures can be golden-tested.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "export/export_scene.h"

namespace oslam {

inline cv::Scalar Bgr(const Rgb& rgb) {
  return cv::Scalar(rgb[2], rgb[1], rgb[0]);
}

// Runs `draw` on a copy of the region `roi` of `image` and blends the result
// back with weight `alpha`; pixels `draw` leaves alone stay unchanged. `draw`
// gets coordinates relative to the region's top-left corner.
void BlendInRegion(cv::Mat* image, cv::Rect roi, double alpha,
                   const std::function<void(cv::Mat* region)>& draw);

// Filled convex polygon / disc, blended with `alpha`.
void BlendPolygon(cv::Mat* image, const std::vector<cv::Point>& points, const cv::Scalar& colour,
                  double alpha);
void BlendDisc(cv::Mat* image, cv::Point centre, int radius, const cv::Scalar& colour, double alpha,
               int outline_thickness = 1);

// Text with a one-pixel light halo so it stays readable on any background,
// moved inside the image when it would cross the border.
void DrawLabel(cv::Mat* image, const std::string& text, cv::Point origin, const cv::Scalar& colour,
               double scale = 0.4);
// The pixels DrawLabel may touch on an image of `image_size` (halo included),
// clipped to the image.
cv::Rect LabelRegion(cv::Size image_size, const std::string& text, cv::Point origin,
                     double scale = 0.4);
// DrawLabel on `region`, a part of a larger image starting at `offset`:
// exactly what DrawLabel on that image would draw there, provided `region`
// contains LabelRegion of the larger image.
void DrawLabelInRegion(cv::Mat* region, cv::Point offset, cv::Size image_size,
                       const std::string& text, cv::Point origin, const cv::Scalar& colour,
                       double scale = 0.4);

// Polyline bounds widened by `margin` pixels (thickness, anti-aliasing),
// clipped to an image of `image_size`.
cv::Rect PolylineRegion(const std::vector<cv::Point>& points, int margin, cv::Size image_size);

// Dotted polyline (the thesis draws the inferred trajectory black dotted).
void DrawDotted(cv::Mat* image, const std::vector<cv::Point2d>& points, const cv::Scalar& colour,
                double spacing_px, int radius_px);

// "0.87": existence probabilities in labels (Hershey fonts have no pi).
std::string FormatProbability(double p);

}  // namespace oslam
