#include "export/export_scene.h"

#include <algorithm>
#include <limits>

namespace oslam {

bool ExportOptions::Validate(std::string* why) const {
  if (!(min_existence >= 0.0 && min_existence <= 1.0)) {
    *why = "min-existence must be in [0, 1]";
    return false;
  }
  if (cylinder_segments < 3) {
    *why = "a cylinder needs at least 3 segments";
    return false;
  }
  if (camera_every < 0) {
    *why = "the camera pose interval must be >= 0 (0 = none)";
    return false;
  }
  return true;
}

std::vector<const OMapObject*> ShownObjects(const OMap& map, double min_existence) {
  std::vector<const OMapObject*> shown;
  for (const OMapObject& object : map.objects)
    if (object.existence_probability >= min_existence) shown.push_back(&object);
  return shown;
}

Rgb ClassColour(const std::vector<ObjectClass>& classes, const std::string& class_name) {
  const int index = FindClass(classes, class_name);
  return index >= 0 ? classes[index].display_rgb : Rgb{128, 128, 128};
}

std::vector<NamedTrajectory> SceneTrajectories(const ExportScene& scene) {
  std::vector<NamedTrajectory> trajectories;
  if (!scene.map.trajectory.empty())
    trajectories.push_back({"estimated", scene.map.trajectory, {0, 0, 0}});
  if (!scene.odometry.empty()) trajectories.push_back({"odometry", scene.odometry, {210, 40, 40}});
  if (!scene.ground_truth.empty())
    trajectories.push_back({"ground truth", scene.ground_truth, {20, 150, 50}});
  return trajectories;
}

Eigen::Vector4d FloorExtent(const ExportScene& scene, double min_existence, double margin_m) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Eigen::Vector4d box(kInf, kInf, -kInf, -kInf);
  auto grow = [&box](double x, double y, double radius) {
    box = {std::min(box[0], x - radius), std::min(box[1], y - radius), std::max(box[2], x + radius),
           std::max(box[3], y + radius)};
  };
  for (const OMapObject* object : ShownObjects(scene.map, min_existence))
    grow(object->base_world.x(), object->base_world.y(), 0.5 * object->diameter_m);
  for (const NamedTrajectory& trajectory : SceneTrajectories(scene))
    for (const Pose2& pose : trajectory.poses) grow(pose.x, pose.y, 0.0);
  if (!(box[0] <= box[2])) box = {-0.5, -0.5, 0.5, 0.5};
  return box + Eigen::Vector4d(-margin_m, -margin_m, margin_m, margin_m);
}

std::string ObjectLabel(const OMapObject& object) {
  return (object.class_name.empty() ? std::string("object") : object.class_name) + " " +
         std::to_string(object.id);
}

}  // namespace oslam
