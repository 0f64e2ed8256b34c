#include "calib/camera_io.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include <opencv2/core.hpp>

#include "calib/hyperbolic_camera.h"
#include "calib/mei_camera.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/text.h"
#include "core/yaml.h"

namespace oslam {

std::unique_ptr<CameraModel> CreateCameraModel(const std::string& model_name) {
  // The one place camera models are registered.
  if (model_name == HyperbolicCamera::kModelName) return std::make_unique<HyperbolicCamera>();
  if (model_name == MeiCamera::kModelName) return std::make_unique<MeiCamera>();
  std::string known;
  for (const auto& name : CameraModelNames()) known += (known.empty() ? "" : ", ") + name;
  throw Error("unknown camera model '" + model_name + "' (known: " + known + ")");
}

std::vector<std::string> CameraModelNames() {
  return {HyperbolicCamera::kModelName, MeiCamera::kModelName};
}

std::unique_ptr<CameraModel> LoadCamera(const std::string& path) {
  YamlFile file(path);
  const cv::FileNode root = file.root();
  file.RequireOnlyKeys(root, "",
                       {"model", "image_width", "image_height", "blind_radius_px", "rim_radius_px",
                        "flip_image_angle", "intrinsics"});
  const std::string model_name = file.String(root, "model");
  std::unique_ptr<CameraModel> camera;
  try {
    camera = CreateCameraModel(model_name);
  } catch (const Error& error) {
    throw Error::InFile(path, error.what());
  }
  camera->set_image_size(file.Int(root, "image_width"), file.Int(root, "image_height"));
  camera->set_annulus({file.Double(root, "blind_radius_px"), file.Double(root, "rim_radius_px")});

  const cv::FileNode intrinsics_node = file.Map(root, "intrinsics");
  const std::vector<std::string> names = camera->IntrinsicNames();
  file.RequireOnlyKeys(intrinsics_node, "intrinsics.", names);
  Eigen::VectorXd intrinsics(names.size());
  for (size_t i = 0; i < names.size(); ++i)
    intrinsics[i] = file.Double(intrinsics_node, names[i], "intrinsics.");
  camera->SetIntrinsics(intrinsics);

  // A flag only the hyperbolic model has: elsewhere a 1 would be dropped
  // unnoticed and every bearing mirrored.
  const int flip = file.OptionalInt(root, "flip_image_angle", 0);
  if (flip != 0 && flip != 1) file.Fail("flip_image_angle", "must be 0 or 1");
  if (auto* hyperbolic = dynamic_cast<HyperbolicCamera*>(camera.get())) {
    HyperbolicMirrorParameters p = hyperbolic->parameters();
    p.flip_image_angle = flip == 1;
    hyperbolic->set_parameters(p);
  } else if (flip == 1) {
    file.Fail("flip_image_angle",
              "only the hyperbolic model has it; the " + model_name + " model does not");
  }
  std::string why;
  if (!camera->Validate(&why)) throw Error::InFile(path, "invalid camera: " + why);
  return camera;
}

void SaveCamera(const CameraModel& camera, const std::string& path) {
  std::string why;
  if (!camera.Validate(&why))
    throw Error::InFile(path, "refusing to save an invalid camera: " + why);
  // Written by hand: cv::FileStorage prints doubles as 5.9999999999999998e-01;
  // Number gives the shortest text that reads back exactly.
  std::ostringstream out;
  out << "%YAML:1.0\n---\n";  // cv::FileStorage needs the directive
  out << "model: " << camera.ModelName() << "\n";
  out << "image_width: " << camera.image_width() << "\n";
  out << "image_height: " << camera.image_height() << "\n";
  out << "blind_radius_px: " << Number(camera.annulus().blind_radius_px) << "\n";
  out << "rim_radius_px: " << Number(camera.annulus().rim_radius_px) << "\n";
  if (const auto* hyperbolic = dynamic_cast<const HyperbolicCamera*>(&camera))
    out << "flip_image_angle: " << (hyperbolic->parameters().flip_image_angle ? 1 : 0) << "\n";
  out << "intrinsics:\n";
  const std::vector<std::string> names = camera.IntrinsicNames();
  const Eigen::VectorXd values = camera.Intrinsics();
  for (size_t i = 0; i < names.size(); ++i)
    out << "  " << names[i] << ": " << Number(values[static_cast<Eigen::Index>(i)]) << "\n";
  WriteFileAtomically(path, out.str());
}

}  // namespace oslam
