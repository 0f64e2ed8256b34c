// camera.yaml: every camera model stored the same way, read and written with
// cv::FileStorage (so OpenCV tools can read it too).
//
//   %YAML:1.0
//   ---
//   model: hyperbolic
//   image_width: 640
//   image_height: 480
//   blind_radius_px: 40.
//   rim_radius_px: 236.
//   flip_image_angle: 0
//   intrinsics:
//      mirror_a_m: 3.929e-02
//      ...           (the model's IntrinsicNames(), all required)
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "calib/camera_model.h"

namespace oslam {

// A default-constructed model of that name; throws oslam::Error for an unknown one.
std::unique_ptr<CameraModel> CreateCameraModel(const std::string& model_name);
std::vector<std::string> CameraModelNames();

// Throws oslam::Error("PATH: problem") on a missing file, a syntax error, a
// missing/unknown/non-finite field or an invalid parameter set.
std::unique_ptr<CameraModel> LoadCamera(const std::string& path);
// Written atomically.
void SaveCamera(const CameraModel& camera, const std::string& path);

}  // namespace oslam
