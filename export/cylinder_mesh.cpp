#include "export/cylinder_mesh.h"

#include <cmath>

namespace oslam {
namespace {

// A cap: centre vertex then a ring; triangles fan from the centre, wound so
// their front faces point along `up` (+1 top, -1 bottom).
void AddCap(TriangleMesh* mesh, float radius, float z, float up, int segments) {
  const auto centre = static_cast<uint32_t>(mesh->positions.size());
  const Eigen::Vector3f normal(0.f, 0.f, up);
  mesh->positions.emplace_back(0.f, 0.f, z);
  mesh->normals.push_back(normal);
  for (int i = 0; i < segments; ++i) {
    const double angle = 2.0 * M_PI * i / segments;
    mesh->positions.emplace_back(radius * std::cos(angle), radius * std::sin(angle), z);
    mesh->normals.push_back(normal);
  }
  for (int i = 0; i < segments; ++i) {
    const uint32_t a = centre + 1 + i, b = centre + 1 + (i + 1) % segments;
    if (up > 0)
      mesh->indices.insert(mesh->indices.end(), {centre, a, b});
    else
      mesh->indices.insert(mesh->indices.end(), {centre, b, a});
  }
}

}  // namespace

TriangleMesh CylinderMesh(double diameter_m, double height_m, int segments) {
  TriangleMesh mesh;
  const auto radius = static_cast<float>(0.5 * diameter_m);
  const auto height = static_cast<float>(height_m);
  // Side: bottom ring at even indices, top ring at odd ones.
  for (int i = 0; i < segments; ++i) {
    const double angle = 2.0 * M_PI * i / segments;
    const Eigen::Vector3f normal(static_cast<float>(std::cos(angle)),
                                 static_cast<float>(std::sin(angle)), 0.f);
    for (const float z : {0.f, height}) {
      mesh.positions.emplace_back(radius * normal.x(), radius * normal.y(), z);
      mesh.normals.push_back(normal);
    }
  }
  for (int i = 0; i < segments; ++i) {
    const auto b0 = static_cast<uint32_t>(2 * i), t0 = b0 + 1;
    const auto b1 = static_cast<uint32_t>(2 * ((i + 1) % segments)), t1 = b1 + 1;
    mesh.indices.insert(mesh.indices.end(), {b0, b1, t1, b0, t1, t0});
  }
  AddCap(&mesh, radius, 0.f, -1.f, segments);
  AddCap(&mesh, radius, height, 1.f, segments);
  return mesh;
}

}  // namespace oslam
