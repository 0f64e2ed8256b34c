// oslam camera: inspect a camera model, or start a run folder's camera.yaml
// from one of the thesis rigs.
#include <cstdio>
#include <iostream>
#include <memory>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "core/angles.h"
#include "core/error.h"

namespace oslam {

namespace {

void PrintCamera(const CameraModel& camera) {
  std::printf("model: %s\nimage: %d x %d px, centre (%.2f, %.2f) px\n", camera.ModelName().c_str(),
              camera.image_width(), camera.image_height(), camera.ImageCenter().x(),
              camera.ImageCenter().y());
  std::printf("mirror annulus: %.1f .. %.1f px\n", camera.annulus().blind_radius_px,
              camera.annulus().rim_radius_px);
  const std::vector<std::string> names = camera.IntrinsicNames();
  const Eigen::VectorXd values = camera.Intrinsics();
  for (size_t i = 0; i < names.size(); ++i) std::printf("  %-18s %.6g\n", names[i].c_str(), values[i]);
  if (const auto* hyperbolic = dynamic_cast<const HyperbolicCamera*>(&camera)) {
    const double inner = hyperbolic->ElevationOfRadius(camera.annulus().blind_radius_px);
    const double outer = hyperbolic->ElevationOfRadius(camera.annulus().rim_radius_px);
    std::printf("horizon radius: %.2f px; elevations seen: %.1f .. %.1f deg\n",
                hyperbolic->HorizonRadius(), RadToDeg(inner), RadToDeg(outer));
    std::printf("image angle flipped: %s\n", hyperbolic->parameters().flip_image_angle ? "yes" : "no");
  }
}

Eigen::Vector3d ParsePoint(const std::string& text) {
  Eigen::Vector3d point;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &point.x(), &point.y(), &point.z(), &extra) != 3)
    throw UsageError("--project expects X,Y,Z in metres, got '" + text + "'");
  return point;
}

}  // namespace

int RunCameraCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam camera (--preset NAME | --from CAMERA.yaml) [-o CAMERA.yaml]",
                      "Prints a camera model's parameters; writes it as camera.yaml with -o.");
  arguments.AddOption("preset", "", "NAME", "a thesis rig: lpa or cogniron");
  arguments.AddOption("from", "", "CAMERA.yaml", "read the camera from this file");
  arguments.AddOption("output", "-o", "CAMERA.yaml", "write the camera here (atomically)");
  arguments.AddOption("project", "", "X,Y,Z", "also project this robot-frame point (metres)");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (arguments.Has("preset") == arguments.Has("from"))
    throw UsageError("give exactly one of --preset and --from");

  std::unique_ptr<CameraModel> camera;
  if (arguments.Has("preset")) {
    try {
      camera = HyperbolicCamera::Preset(arguments.Get("preset")).Clone();
    } catch (const Error& e) {
      throw UsageError(e.what());
    }
  } else {
    camera = LoadCamera(arguments.Get("from"));
  }
  const bool quiet = arguments.Flag("quiet");
  if (!quiet) PrintCamera(*camera);
  if (arguments.Has("project")) {
    const Eigen::Vector3d point = ParsePoint(arguments.Get("project"));
    PolarPoint polar;
    Eigen::Vector2d pixel;
    if (!camera->ProjectToPixel(point, &pixel) || !camera->ProjectToPolar(point, &polar))
      throw Error("point (" + arguments.Get("project") + ") has no image in this camera");
    std::printf("point (%.3f, %.3f, %.3f) m -> pixel (%.3f, %.3f), polar (%.3f px, %.5f rad)%s\n",
                point.x(), point.y(), point.z(), pixel.x(), pixel.y(), polar.radius_px,
                polar.angle_rad, camera->IsInAnnulus(pixel) ? "" : " [outside the mirror annulus]");
  }
  if (arguments.Has("output")) {
    SaveCamera(*camera, arguments.Get("output"));
    if (!quiet) std::printf("wrote %s\n", arguments.Get("output").c_str());
  }
  return 0;
}

}  // namespace oslam
