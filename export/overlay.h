// Reprojection overlays (thesis figs. 6.4b, 6.11): every shown map object's
// predicted bounding slice in a frame, seen from the estimated pose of that
// frame, in its class colour, faded by its existence probability and labelled
// with class, id and pi; the frame's detections drawn thin in white on top.
#pragma once

#include <vector>

#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "detect/blob_detector.h"
#include "export/export_scene.h"

namespace oslam {

// `frame` is BGR 8-bit; `detections` are those of this frame (others are
// ignored). Throws oslam::Error when the map has no estimated pose for the
// frame.
cv::Mat DrawOverlay(const cv::Mat& frame, long frame_index, const CameraModel& camera,
                    const ExportScene& scene, const std::vector<Detection>& detections,
                    double min_existence);

}  // namespace oslam
