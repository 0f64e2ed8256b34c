#include "export/overlay.h"

#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "export/raster.h"
#include "calib/observation_model.h"

namespace oslam {
namespace {

// A predicted slice is drawn only when some of it lies in the mirror
// annulus; the rest would be drawn off the mirror where nothing is seen.
bool TouchesAnnulus(const CameraModel& camera, const BoundingSlice& slice) {
  const MirrorAnnulus& annulus = camera.annulus();
  if (annulus.rim_radius_px <= 0.0) return true;  // no annulus known: draw all
  return slice.u_r_px <= annulus.rim_radius_px &&
         slice.u_r_px + slice.s_r_px >= annulus.blind_radius_px;
}

void DrawPrediction(cv::Mat* image, const CameraModel& camera, const OMapObject& object,
                    const BoundingSlice& slice, const Rgb& rgb) {
  // Each layer is blended over the pixels it can touch only (a blend leaves
  // untouched pixels as they are, so the result is that of blending the
  // whole image, at a fraction of the cost).
  const double alpha = object.existence_probability;
  const std::vector<cv::Point> outline = SliceOutline(camera, slice);
  const cv::Rect slice_region = PolylineRegion(outline, 4, image->size());
  BlendInRegion(image, slice_region, alpha, [&](cv::Mat* layer) {
    std::vector<cv::Point> local;
    local.reserve(outline.size());
    for (const cv::Point& p : outline) local.push_back(p - slice_region.tl());
    cv::polylines(*layer, local, true, Bgr(rgb), 2, cv::LINE_AA);
  });
  // Label just outside the slice's outer arc, at its middle angle.
  const Eigen::Vector2d anchor =
      camera.PolarToPixel({slice.u_r_px + slice.s_r_px + 6.0, slice.u_phi_rad});
  const cv::Point origin(cvRound(anchor.x()), cvRound(anchor.y()));
  const std::string text = ObjectLabel(object) + " " + FormatProbability(alpha);
  const cv::Rect label_region = LabelRegion(image->size(), text, origin, 0.35);
  BlendInRegion(image, label_region, std::max(alpha, 0.35), [&](cv::Mat* layer) {
    DrawLabelInRegion(layer, label_region.tl(), image->size(), text, origin, Bgr(rgb), 0.35);
  });
}

void DrawDetection(cv::Mat* image, const CameraModel& camera, const Detection& detection,
                   const Rgb& rgb) {
  DrawSlice(image, camera, detection.slice, cv::Scalar(255, 255, 255), 1);
  const Eigen::Vector2d base =
      camera.PolarToPixel({detection.slice.u_r_px, detection.slice.u_phi_rad});
  cv::circle(*image, cv::Point(cvRound(base.x()), cvRound(base.y())), 2, Bgr(rgb), cv::FILLED,
             cv::LINE_AA);
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
  for (const OMapObject* object : ShownObjects(scene.map, min_existence)) {
    BoundingSlice slice;
    const CylinderGeometry geometry{object->base_world, object->diameter_m, object->height_m};
    if (!PredictSlice(camera, pose, geometry, &slice) || !TouchesAnnulus(camera, slice)) continue;
    DrawPrediction(&image, camera, *object, slice, ClassColour(scene.classes, object->class_name));
  }
  for (const Detection& detection : detections)
    if (detection.frame == frame_index)
      DrawDetection(&image, camera, detection, ClassColour(scene.classes, detection.class_name));
  DrawLabel(&image, "frame " + std::to_string(frame_index), cv::Point(6, 14), cv::Scalar(0, 0, 0),
            0.4);
  DrawLabel(&image, "map: colour, faded by p; detections: white", cv::Point(6, image.rows - 6),
            cv::Scalar(0, 0, 0), 0.35);
  return image;
}

}  // namespace oslam
