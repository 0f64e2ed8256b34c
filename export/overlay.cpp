#include "export/overlay.h"

#include <algorithm>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "calib/observation_model.h"
#include "core/error.h"
#include "export/label_layout.h"

namespace oslam {
namespace {

constexpr double kTextScale = 0.38;  // Hershey simplex: about 9 px tall
constexpr int kHalo = 3;             // light outline that keeps text readable on any frame

cv::Scalar Bgr(const Rgb& rgb) {
  return cv::Scalar(rgb[2], rgb[1], rgb[0]);
}

// Runs `draw` on a copy of the region `roi` of `image` and blends the result
// back with weight `alpha`; pixels `draw` leaves alone stay as they were (so
// the result is that of blending a whole layer, at a fraction of the cost).
// `draw` gets coordinates relative to the region's top-left corner.
template <typename Draw>
void BlendInRegion(cv::Mat* image, cv::Rect roi, double alpha, const Draw& draw) {
  roi &= cv::Rect(0, 0, image->cols, image->rows);
  if (roi.empty() || alpha <= 0.0) return;
  cv::Mat target = (*image)(roi);
  cv::Mat layer = target.clone();
  draw(&layer, roi.tl());
  cv::addWeighted(layer, std::min(alpha, 1.0), target, 1.0 - std::min(alpha, 1.0), 0.0, target);
}

cv::Size TextSize(const std::string& text, int* baseline) {
  return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, kTextScale, 1, baseline);
}

// Text with a light halo, its box's top-left corner at `corner`. The halo
// is drawn without anti-aliasing: the anti-aliased text on it hides its
// edge, and a thick anti-aliased stroke cost two thirds of an overlay's
// drawing time (docs/benchmarks.md, "Export").
void PutText(cv::Mat* image, const std::string& text, cv::Point corner, const cv::Scalar& colour) {
  int baseline = 0;
  const cv::Size size = TextSize(text, &baseline);
  const cv::Point origin(corner.x, corner.y + size.height);
  cv::putText(*image, text, origin, cv::FONT_HERSHEY_SIMPLEX, kTextScale, cv::Scalar(255, 255, 255),
              kHalo, cv::LINE_8);
  cv::putText(*image, text, origin, cv::FONT_HERSHEY_SIMPLEX, kTextScale, colour, 1, cv::LINE_AA);
}

// A label's box (halo and descenders included) for text whose top-left
// corner is at the origin.
cv::Size2d LabelSize(const std::string& text) {
  int baseline = 0;
  const cv::Size size = TextSize(text, &baseline);
  return {static_cast<double>(size.width + 2 * kHalo),
          static_cast<double>(size.height + baseline + 2 * kHalo)};
}

// A predicted slice is drawn only when some of it lies in the mirror
// annulus; the rest would be drawn off the mirror where nothing is seen.
bool TouchesAnnulus(const CameraModel& camera, const BoundingSlice& slice) {
  const MirrorAnnulus& annulus = camera.annulus();
  if (annulus.rim_radius_px <= 0.0) return true;  // no annulus known: draw all
  return slice.u_r_px <= annulus.rim_radius_px &&
         slice.u_r_px + slice.s_r_px >= annulus.blind_radius_px;
}

// What the solver predicts for an object (docs/method.md §4.2): its class's
// silhouette, a panel's from its orientation when the map has one (else
// from the mean extents); the thesis' section for an object of no known
// class.
SilhouetteModel ObjectSilhouette(const CameraModel& camera, const std::vector<ObjectClass>& classes,
                                 const OMapObject& object) {
  const auto found = std::find_if(classes.begin(), classes.end(), [&](const ObjectClass& c) {
    return c.name == object.class_name;
  });
  if (found == classes.end()) return {};
  SilhouetteModel silhouette = SilhouetteOf(camera, found->shape, found->footprint_aspect);
  if (!object.yaw_rad) silhouette.panel = false;
  return silhouette;
}

struct ObjectLabelToDraw {
  std::string text;
  cv::Point2d anchor;  // the middle of the slice's outer arc
  cv::Rect2d slice;    // the slice's bounding box
  Rgb rgb;
  double alpha;
};

// Returns the outline's bounding box.
cv::Rect DrawPrediction(cv::Mat* image, const CameraModel& camera, const BoundingSlice& slice,
                        const Rgb& rgb, double alpha) {
  const std::vector<cv::Point> outline = SliceOutline(camera, slice);
  if (outline.empty()) return {};
  const cv::Rect bounds = cv::boundingRect(outline);
  cv::Rect region = bounds;
  region = cv::Rect(region.x - 4, region.y - 4, region.width + 8, region.height + 8);
  BlendInRegion(image, region, alpha, [&](cv::Mat* layer, cv::Point offset) {
    std::vector<cv::Point> local;
    local.reserve(outline.size());
    for (const cv::Point& p : outline) local.push_back(p - offset);
    cv::polylines(*layer, local, true, Bgr(rgb), 2, cv::LINE_AA);
  });
  return bounds;
}

void DrawDetection(cv::Mat* image, const CameraModel& camera, const Detection& detection,
                   const Rgb& rgb) {
  DrawSlice(image, camera, detection.slice, cv::Scalar(255, 255, 255), 1);
  const Eigen::Vector2d base =
      camera.PolarToPixel({detection.slice.u_r_px, detection.slice.u_phi_rad});
  cv::circle(*image, cv::Point(cvRound(base.x()), cvRound(base.y())), 2, Bgr(rgb), cv::FILLED,
             cv::LINE_AA);
}

std::string Probability(double p) {
  char text[16];
  std::snprintf(text, sizeof(text), "%.2f", p);
  return text;
}

}  // namespace

cv::Mat DrawOverlay(const cv::Mat& frame, long frame_index, const CameraModel& camera,
                    const ExportScene& scene, const std::vector<Detection>& detections,
                    double min_existence) {
  const std::vector<Pose2>& trajectory = scene.map.trajectory;
  if (frame_index < 0 || frame_index >= static_cast<long>(trajectory.size()))
    throw Error("overlay: the O-Map has no estimated pose for frame " +
                std::to_string(frame_index) + " (trajectory has " +
                std::to_string(trajectory.size()) + " poses)");
  cv::Mat image = frame.clone();
  const Pose2& pose = trajectory[frame_index];
  std::vector<ObjectLabelToDraw> labels;
  for (const OMapObject* object : ShownObjects(scene.map, min_existence)) {
    BoundingSlice slice;
    CylinderGeometry geometry{object->base_world, object->diameter_m, object->height_m};
    const SilhouetteModel silhouette = ObjectSilhouette(camera, scene.classes, *object);
    geometry.yaw_rad = object->yaw_rad.value_or(0.0);
    if (!PredictSlice(camera, pose, geometry, &slice, nullptr, silhouette) ||
        !TouchesAnnulus(camera, slice))
      continue;
    const Rgb rgb = ClassColour(scene.classes, object->class_name);
    const cv::Rect bounds =
        DrawPrediction(&image, camera, slice, rgb, object->existence_probability);
    const Eigen::Vector2d arc = camera.PolarToPixel({slice.u_r_px + slice.s_r_px, slice.u_phi_rad});
    labels.push_back({ObjectLabel(*object) + " " + Probability(object->existence_probability),
                      {arc.x(), arc.y()},
                      bounds,
                      rgb,
                      object->existence_probability});
  }
  for (const Detection& detection : detections)
    if (detection.frame == frame_index)
      DrawDetection(&image, camera, detection, ClassColour(scene.classes, detection.class_name));

  // The frame number top left and the key along the bottom; the object
  // labels are placed around them and around each other.
  const std::vector<std::string> texts = {
      "frame " + std::to_string(frame_index),
      "map: predicted outline in class colour, opacity = existence probability",
      "detections: white outline, dot at the base"};
  std::vector<cv::Rect2d> boxes;
  double bottom = image.rows - 2.0;
  for (size_t k = 0; k < texts.size(); ++k) {
    const cv::Size2d size = LabelSize(texts[k]);
    if (k == 0) {
      boxes.emplace_back(2.0, 2.0, size.width, size.height);
    } else {
      boxes.emplace_back(2.0, bottom - (texts.size() - k) * size.height, size.width, size.height);
    }
  }
  // No label covers a predicted outline.
  for (const ObjectLabelToDraw& label : labels) boxes.push_back(label.slice);
  std::vector<LabelRequest> requests;
  for (const ObjectLabelToDraw& label : labels)
    requests.push_back({label.anchor, LabelSize(label.text), {2.0, 2.0}});
  const std::vector<PlacedLabel> placed =
      PlaceLabels(requests, cv::Rect2d(0, 0, image.cols, image.rows), boxes, 3.0);
  for (size_t i = 0; i < labels.size(); ++i) {
    const cv::Rect box = placed[i].box;
    const cv::Point2d end = NearestPointOnBox(placed[i].box, labels[i].anchor);
    cv::Rect region =
        box | cv::Rect(cv::Point(cvRound(labels[i].anchor.x), cvRound(labels[i].anchor.y)),
                       cv::Size(1, 1));
    region = cv::Rect(region.x - 2, region.y - 2, region.width + 4, region.height + 4);
    // Text stays legible for unlikely objects: at least 60 % opaque.
    BlendInRegion(
        &image, region, std::max(labels[i].alpha, 0.6), [&](cv::Mat* layer, cv::Point offset) {
          if (placed[i].needs_leader)
            cv::line(*layer,
                     cv::Point(cvRound(labels[i].anchor.x), cvRound(labels[i].anchor.y)) - offset,
                     cv::Point(cvRound(end.x), cvRound(end.y)) - offset, Bgr(labels[i].rgb), 1,
                     cv::LINE_AA);
          PutText(layer, labels[i].text, box.tl() + cv::Point(kHalo, kHalo) - offset,
                  Bgr(labels[i].rgb));
        });
  }
  for (size_t k = 0; k < texts.size(); ++k)
    PutText(&image, texts[k], cv::Point(cvRound(boxes[k].x) + kHalo, cvRound(boxes[k].y) + kHalo),
            cv::Scalar(0, 0, 0));
  return image;
}

}  // namespace oslam
