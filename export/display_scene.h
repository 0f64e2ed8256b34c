// The 3D scene every 3D exporter draws (glTF, PLY, the VTK views), built once
// so they all show the same: objects in the shape of their class with their
// colour and opacity pi, trajectories as tubes, optional camera pyramids, and
// the floor extent. World frame, Z up, metres.
#pragma once

#include <string>
#include <vector>

#include "export/export_scene.h"
#include "export/shape_mesh.h"

namespace oslam {

struct DisplayObject {
  const OMapObject* object = nullptr;  // points into the ExportScene's map
  std::string label;                   // ObjectLabel: node, material and label name
  ObjectShape shape = ObjectShape::kCylinder;
  Rgb rgb{};
  double alpha = 1.0;  // the existence probability pi (docs/method.md §2)
  // Which way a box or panel faces (radians, from +x): towards the nearest
  // estimated robot position, since the O-Map has no orientation.
  double yaw_rad = 0.0;
  ClosedMesh local;  // base centre at the origin, yaw applied
  ClosedMesh World() const;
};

struct DisplayTrajectory {
  std::string name;  // "estimated", "odometry", "ground truth"
  Rgb rgb{};
  double z_m = 0.0;  // height of the tube's axis
  ClosedMesh tube;   // world; empty when the trajectory has fewer than two positions
};

struct DisplayScene {
  std::vector<DisplayObject> objects;
  std::vector<DisplayTrajectory> trajectories;
  ClosedMesh cameras;           // world; empty unless ExportOptions::camera_every > 0
  Eigen::Vector4d floor;        // x_min, y_min, x_max, y_max
  double grid_step_m = 1.0;     // floor grid spacing
  double tube_radius_m = 0.01;  // trajectory tubes
};

DisplayScene BuildDisplayScene(const ExportScene& scene, const ExportOptions& options);

// The class's shape, cylinder when the class is unknown.
ObjectShape ClassShape(const std::vector<ObjectClass>& classes, const std::string& class_name);

// Grid spacing for a floor of that extent: 1 m, or 2, 5, 10, ... m so that
// there are at most about 30 lines along the longer side.
double FloorGridStep(const Eigen::Vector4d& floor);

}  // namespace oslam
