// Triangle mesh of an upright cylinder (the O-Map object shape, docs/method.md §2):
// flat-shaded caps and a smooth side, counter-clockwise seen from outside.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace oslam {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;  // unit, one per position
  std::vector<uint32_t> indices;         // three per triangle
};

// Base centre at the origin, axis along +z, `segments` facets around. The
// caps have their own vertices so their normals are exactly -z / +z while the
// side normals point radially outwards.
TriangleMesh CylinderMesh(double diameter_m, double height_m, int segments);

}  // namespace oslam
