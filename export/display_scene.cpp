#include "export/display_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/angles.h"

namespace oslam {
namespace {

// Boxes and panels face the robot's path: towards the estimated position
// nearest to the object (or odometry's, or ground truth's, whichever exists).
double FacingYaw(const OMapObject& object, const std::vector<NamedTrajectory>& trajectories) {
  if (trajectories.empty()) return 0.0;
  const Eigen::Vector2d base = object.base_world.head<2>();
  double best = std::numeric_limits<double>::infinity(), yaw = 0.0;
  for (const Pose2& pose : trajectories.front().poses) {
    const Eigen::Vector2d to_pose = Eigen::Vector2d(pose.x, pose.y) - base;
    if (to_pose.norm() < best && to_pose.norm() > 1e-6) {
      best = to_pose.norm();
      yaw = std::atan2(to_pose.y(), to_pose.x());
    }
  }
  return yaw;
}

}  // namespace

ClosedMesh DisplayObject::World() const {
  ClosedMesh world = local;
  world.Transform(Eigen::Affine3f(Eigen::Translation3f(object->base_world.cast<float>())));
  return world;
}

ObjectShape ClassShape(const std::vector<ObjectClass>& classes, const std::string& class_name) {
  const int index = FindClass(classes, class_name);
  return index >= 0 ? classes[index].shape : ObjectShape::kCylinder;
}

double FloorGridStep(const Eigen::Vector4d& floor) {
  const double longer = std::max(floor[2] - floor[0], floor[3] - floor[1]);
  for (double decade = 1.0;; decade *= 10.0)
    for (const double mantissa : {1.0, 2.0, 5.0})
      if (longer / (mantissa * decade) <= 30.0) return mantissa * decade;
}

DisplayScene BuildDisplayScene(const ExportScene& scene, const ExportOptions& options) {
  DisplayScene display;
  display.floor = FloorExtent(scene, options.min_existence, 0.5);
  display.grid_step_m = FloorGridStep(display.floor);
  const double diagonal =
      Eigen::Vector2d(display.floor[2] - display.floor[0], display.floor[3] - display.floor[1])
          .norm();
  // 1.7 cm in a room 6 m across, thicker in larger maps so the tubes stay
  // visible in an overview.
  display.tube_radius_m = std::max(0.01, 0.002 * diagonal);

  const std::vector<NamedTrajectory> trajectories = SceneTrajectories(scene);
  for (const OMapObject* object : ShownObjects(scene.map, options.min_existence)) {
    DisplayObject shown;
    shown.object = object;
    shown.label = ObjectLabel(*object);
    shown.shape = ClassShape(scene.classes, object->class_name);
    shown.rgb = ClassColour(scene.classes, object->class_name);
    shown.alpha = std::clamp(object->existence_probability, 0.0, 1.0);
    if (shown.shape == ObjectShape::kBox || shown.shape == ObjectShape::kPanel)
      shown.yaw_rad = FacingYaw(*object, trajectories);
    // A panel with an estimated orientation: its width (the mesh's local y)
    // along that yaw, its face towards the path.
    if (shown.shape == ObjectShape::kPanel && object->yaw_rad) {
      const double normal = *object->yaw_rad - 0.5 * kPi;
      shown.yaw_rad = std::cos(normal - shown.yaw_rad) >= 0 ? normal : normal + kPi;
    }
    shown.local =
        ShapeMesh(shown.shape, object->diameter_m, object->height_m, options.cylinder_segments);
    shown.local.Transform(Eigen::Affine3f(
        Eigen::AngleAxisf(static_cast<float>(shown.yaw_rad), Eigen::Vector3f::UnitZ())));
    display.objects.push_back(std::move(shown));
  }

  // Stacked so none hides another where they coincide: ground truth lowest,
  // the estimate on top.
  const double r = display.tube_radius_m;
  for (const NamedTrajectory& trajectory : trajectories) {
    DisplayTrajectory tube;
    tube.name = trajectory.name;
    tube.rgb = trajectory.rgb;
    tube.z_m = trajectory.name == "ground truth" ? r
               : trajectory.name == "odometry"   ? 3 * r
                                                 : 5 * r;
    std::vector<Eigen::Vector2d> points;
    for (const Pose2& pose : trajectory.poses) points.emplace_back(pose.x, pose.y);
    tube.tube = TubeMesh(points, tube.z_m, r, 12);
    display.trajectories.push_back(std::move(tube));
  }

  if (options.camera_every > 0) {
    const ClosedMesh pyramid = PyramidMesh(10.0 * r);
    const std::vector<Pose2>& poses = scene.map.trajectory;
    for (size_t i = 0; i < poses.size(); i += static_cast<size_t>(options.camera_every)) {
      ClosedMesh camera = pyramid;
      camera.Transform(
          Eigen::Translation3f(static_cast<float>(poses[i].x), static_cast<float>(poses[i].y),
                               static_cast<float>(6 * r)) *
          Eigen::AngleAxisf(static_cast<float>(poses[i].theta), Eigen::Vector3f::UnitZ()));
      display.cameras.Append(camera);
    }
  }
  return display;
}

}  // namespace oslam
