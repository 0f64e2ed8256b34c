// A small fixed O-Map scene for the export tests: four objects, one of each
// shape (the door below the default existence threshold), four classes, and
// estimated, odometry
// and ground-truth trajectories on a 1.2 m circle. Built in code so the
// expected values are visible next to the checks.
#pragma once

#include <cmath>

#include "export/export_scene.h"

namespace oslam::testing {

inline OMapObject FixtureObject(int id, const std::string& class_name, Eigen::Vector3d base,
                                double diameter, double height, double pi) {
  OMapObject object;
  object.id = id;
  object.class_name = class_name;
  object.base_world = base;
  object.diameter_m = diameter;
  object.height_m = height;
  object.existence_probability = pi;
  object.num_detections = 10 * id;
  for (int k = 0; k < 5; ++k) object.covariance(k, k) = 0.01 * (k + 1);
  object.covariance(0, 1) = object.covariance(1, 0) = 0.002;
  object.class_histogram = {{class_name, 0.9}, {"other", 0.1}};
  return object;
}

inline ObjectClass FixtureClass(const std::string& name, Rgb rgb,
                                ObjectShape shape = ObjectShape::kCylinder) {
  ObjectClass c;
  c.name = name;
  c.display_rgb = rgb;
  c.shape = shape;
  return c;
}

inline ExportScene FixtureScene() {
  ExportScene scene;
  scene.map.objects = {
      FixtureObject(1, "green box", {1.0, 0.5, 0.0}, 0.6, 0.57, 1.0),
      FixtureObject(2, "pink ball", {-0.8, 1.2, 0.05}, 0.25, 0.25, 0.6),
      FixtureObject(3, "orange door", {0.3, -1.6, 0.0}, 1.0, 2.1, 0.05),
      FixtureObject(4, "Magellan", {-0.6, -0.5, 0.0}, 0.5, 0.3, 0.85),
  };
  scene.classes = {FixtureClass("green box", {40, 150, 60}, ObjectShape::kBox),
                   FixtureClass("pink ball", {240, 110, 170}, ObjectShape::kSphere),
                   FixtureClass("orange door", {235, 115, 45}, ObjectShape::kPanel),
                   FixtureClass("Magellan", {150, 40, 40})};
  constexpr int kPoses = 24;
  for (int i = 0; i < kPoses; ++i) {
    const double a = 2.0 * M_PI * i / kPoses;
    const Pose2 truth{1.2 * std::cos(a), 1.2 * std::sin(a), a + M_PI / 2};
    scene.ground_truth.push_back(truth);
    // Estimate: small wobble; odometry: a drift growing with time.
    scene.map.trajectory.push_back({truth.x + 0.03 * std::sin(3 * a), truth.y, truth.theta});
    scene.odometry.push_back({truth.x * (1 + 0.01 * i), truth.y + 0.01 * i, truth.theta});
  }
  return scene;
}

}  // namespace oslam::testing
