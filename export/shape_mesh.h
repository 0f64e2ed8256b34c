// The triangle meshes every exporter draws: an object in the shape of its
// class (cylinder, box, sphere, panel), a trajectory as a thin tube, a camera
// pose as a small pyramid. All are closed, with shared vertices (every edge
// belongs to exactly two triangles, wound counter-clockwise seen from
// outside), so they can be drawn single-sided (no inner faces show through
// a transparent object) and PLY viewers find them watertight.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/run_folder.h"

namespace oslam {

struct ClosedMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::array<uint32_t, 3>> triangles;
  // Per triangle: triangles of one group are shaded smoothly across shared
  // vertices; between groups (a cylinder's side and cap, a box's faces) the
  // edge stays sharp.
  std::vector<uint8_t> groups;

  void Transform(const Eigen::Affine3f& transform);
  // Appends `other`, its vertices after this mesh's.
  void Append(const ClosedMesh& other);
};

// Triangles with one normal per vertex, vertices split where groups meet:
// what a renderer draws.
struct ShadedMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;  // unit, one per position
  std::vector<uint32_t> indices;         // three per triangle
};

ShadedMesh Shade(const ClosedMesh& mesh);

// An object of the given diameter and height (docs/method.md §2): base centre
// at the origin, Z up, `segments` facets around the round shapes.
//  - cylinder: the method's own shape;
//  - box: square footprint whose diagonal is the diameter (the method's
//    convention for boxes, §2), sides along x and y;
//  - sphere: an ellipsoid, the diameter across and the height tall;
//  - panel: a thin slab as wide as the diameter, its faces along +-x.
// Sizes below 1 mm are drawn as 1 mm so no triangle degenerates.
ClosedMesh ShapeMesh(ObjectShape shape, double diameter_m, double height_m, int segments);

// A tube of `radius_m` with flat end caps along a polyline of floor points
// (x, y) at height `z_m`; repeated points are skipped. Rings at corners lie in
// the bisecting plane, so the tube keeps its width around a turn. Empty when
// fewer than two distinct points remain.
ClosedMesh TubeMesh(const std::vector<Eigen::Vector2d>& points, double z_m, double radius_m,
                    int sides);

// A square pyramid with its apex at the origin opening along +x: a camera's
// view direction, `length_m` deep and as wide.
ClosedMesh PyramidMesh(double length_m);

}  // namespace oslam
