// What every exporter draws: the O-Map, the class display colours, and the
// trajectories to compare it with. Shared conventions (docs/method.md §2): an object's
// opacity is its existence probability pi, objects with pi below a threshold
// are left out, the class colour is the display colour of classes.yaml.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/pose2.h"
#include "core/run_folder.h"
#include "omap/omap.h"

namespace oslam {

using Rgb = std::array<int, 3>;  // 0..255, sRGB

struct ExportScene {
  OMap map;
  std::vector<ObjectClass> classes;  // for display colours; unknown classes are grey
  std::vector<Pose2> odometry;       // optional (empty = absent), one per frame
  std::vector<Pose2> ground_truth;   // optional (empty = absent), one per frame
};

struct ExportOptions {
  double min_existence = 0.0;  // objects with pi below this are left out
  bool floor_grid = true;      // glTF: a grid on the floor plane (context only, docs/method.md §2)
  int cylinder_segments = 32;  // facets around the round shapes (cylinder, sphere)
  int camera_every = 0;        // glTF: a camera pyramid at every Nth estimated pose (0 = none)
  bool Validate(std::string* why) const;
};

// One polyline of robot positions on the floor, in its display colour.
struct NamedTrajectory {
  std::string name;  // "estimated", "odometry", "ground truth"
  std::vector<Pose2> poses;
  Rgb rgb{};
};

// The objects an exporter shows, in map order.
std::vector<const OMapObject*> ShownObjects(const OMap& map, double min_existence);
// The class's display colour, grey when the class is unknown.
Rgb ClassColour(const std::vector<ObjectClass>& classes, const std::string& class_name);
// Estimated (black, as the thesis' inferred trajectory), odometry (red) and
// ground truth (green, as the thesis' laser reference), those that are present.
std::vector<NamedTrajectory> SceneTrajectories(const ExportScene& scene);

// World (Z up) to glTF (Y up): x -> x, z -> y, y -> -z. A proper rotation
// (-90 degrees about x), so handedness and triangle winding are kept.
inline Eigen::Vector3d ZUpToYUp(const Eigen::Vector3d& p) {
  return {p.x(), p.z(), -p.y()};
}

// Axis-aligned floor extent (x_min, y_min, x_max, y_max) of the shown objects
// and all trajectories, grown by `margin_m`; a 1 m square around the origin
// when the scene is empty.
Eigen::Vector4d FloorExtent(const ExportScene& scene, double min_existence, double margin_m);

// "green box 3" - the glTF node name and the label used in figures.
std::string ObjectLabel(const OMapObject& object);

}  // namespace oslam
