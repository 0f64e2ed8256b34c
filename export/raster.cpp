#include "export/raster.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace oslam {

void BlendInRegion(cv::Mat* image, cv::Rect roi, double alpha,
                   const std::function<void(cv::Mat* region)>& draw) {
  roi &= cv::Rect(0, 0, image->cols, image->rows);
  if (roi.empty() || alpha <= 0.0) return;
  cv::Mat target = (*image)(roi);
  cv::Mat layer = target.clone();
  draw(&layer);
  cv::addWeighted(layer, std::min(alpha, 1.0), target, 1.0 - std::min(alpha, 1.0), 0.0, target);
}

void BlendDisc(cv::Mat* image, cv::Point centre, int radius, const cv::Scalar& colour, double alpha,
               int outline_thickness) {
  const int r = std::max(radius, 1);
  const cv::Rect box(centre.x - r - 2, centre.y - r - 2, 2 * r + 5, 2 * r + 5);
  BlendInRegion(image, box, alpha, [&](cv::Mat* region) {
    const cv::Point local = centre - box.tl();
    cv::circle(*region, local, r, colour, cv::FILLED, cv::LINE_AA);
    if (outline_thickness > 0)
      cv::circle(*region, local, r, colour * 0.6, outline_thickness, cv::LINE_AA);
  });
}

namespace {

constexpr int kLabelThickness = 3;  // the halo

// DrawLabel's origin: moved inside the image, since a label cut off at the
// border is useless.
cv::Point LabelOrigin(cv::Size image_size, const std::string& text, cv::Point origin, double scale,
                      cv::Size* text_size, int* baseline) {
  *text_size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, kLabelThickness, baseline);
  origin.x = std::max(2, std::min(origin.x, image_size.width - 2 - text_size->width));
  origin.y = std::max(text_size->height + 2, std::min(origin.y, image_size.height - 2 - *baseline));
  return origin;
}

void PutLabel(cv::Mat* image, const std::string& text, cv::Point origin, const cv::Scalar& colour,
              double scale) {
  cv::putText(*image, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255),
              kLabelThickness, cv::LINE_AA);
  cv::putText(*image, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

}  // namespace

void DrawLabel(cv::Mat* image, const std::string& text, cv::Point origin, const cv::Scalar& colour,
               double scale) {
  cv::Size size;
  int baseline = 0;
  origin = LabelOrigin(image->size(), text, origin, scale, &size, &baseline);
  PutLabel(image, text, origin, colour, scale);
}

cv::Rect LabelRegion(cv::Size image_size, const std::string& text, cv::Point origin, double scale) {
  cv::Size size;
  int baseline = 0;
  origin = LabelOrigin(image_size, text, origin, scale, &size, &baseline);
  // Hershey strokes, the halo and anti-aliasing reach a few pixels beyond
  // getTextSize's box: a wide margin costs little.
  const int margin = 8 + kLabelThickness;
  const cv::Rect box(origin.x - margin, origin.y - size.height - margin, size.width + 2 * margin,
                     size.height + baseline + 2 * margin);
  return box & cv::Rect(cv::Point(0, 0), image_size);
}

void DrawLabelInRegion(cv::Mat* region, cv::Point offset, cv::Size image_size,
                       const std::string& text, cv::Point origin, const cv::Scalar& colour,
                       double scale) {
  cv::Size size;
  int baseline = 0;
  origin = LabelOrigin(image_size, text, origin, scale, &size, &baseline);
  PutLabel(region, text, origin - offset, colour, scale);
}

cv::Rect PolylineRegion(const std::vector<cv::Point>& points, int margin, cv::Size image_size) {
  if (points.empty()) return {};
  cv::Rect box = cv::boundingRect(points);
  box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin);
  return box & cv::Rect(cv::Point(0, 0), image_size);
}

void DrawDotted(cv::Mat* image, const std::vector<cv::Point2d>& points, const cv::Scalar& colour,
                double spacing_px, int radius_px) {
  // Dots at equal arc length along the whole polyline, so the spacing does
  // not restart at every (possibly very short) segment.
  double travelled = 0.0, next_dot = 0.0;
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    const cv::Point2d a = points[i], b = points[i + 1];
    const double length = std::hypot(b.x - a.x, b.y - a.y);
    if (length <= 0.0) continue;
    for (; next_dot <= travelled + length; next_dot += spacing_px) {
      const cv::Point2d p = a + (b - a) * ((next_dot - travelled) / length);
      cv::circle(*image, cv::Point(cvRound(p.x), cvRound(p.y)), radius_px, colour, cv::FILLED,
                 cv::LINE_AA);
    }
    travelled += length;
  }
}

std::string FormatProbability(double p) {
  char text[16];
  std::snprintf(text, sizeof(text), "%.2f", p);
  return text;
}

}  // namespace oslam
