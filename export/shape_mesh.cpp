#include "export/shape_mesh.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace oslam {
namespace {

constexpr float kMinSizeM = 1e-3f;

uint32_t AddVertex(ClosedMesh* mesh, float x, float y, float z) {
  mesh->positions.emplace_back(x, y, z);
  return static_cast<uint32_t>(mesh->positions.size() - 1);
}

void AddTriangle(ClosedMesh* mesh, uint32_t a, uint32_t b, uint32_t c, uint8_t group) {
  mesh->triangles.push_back({a, b, c});
  mesh->groups.push_back(group);
}

// Quad a-b-c-d, counter-clockwise seen from outside.
void AddQuad(ClosedMesh* mesh, uint32_t a, uint32_t b, uint32_t c, uint32_t d, uint8_t group) {
  AddTriangle(mesh, a, b, c, group);
  AddTriangle(mesh, a, c, d, group);
}

// A fan from `centre` over a closed ring; `outward_along_ring` when the ring
// runs counter-clockwise seen from the side the fan faces.
void AddFan(ClosedMesh* mesh, uint32_t centre, const std::vector<uint32_t>& ring,
            bool outward_along_ring, uint8_t group) {
  const size_t n = ring.size();
  for (size_t i = 0; i < n; ++i) {
    const uint32_t a = ring[i], b = ring[(i + 1) % n];
    if (outward_along_ring)
      AddTriangle(mesh, centre, a, b, group);
    else
      AddTriangle(mesh, centre, b, a, group);
  }
}

// Joins two rings of equal size with quads; both rings run counter-clockwise
// about the axis from `lower` to `upper`, so the quads face outwards.
void AddBand(ClosedMesh* mesh, const std::vector<uint32_t>& lower,
             const std::vector<uint32_t>& upper, uint8_t group) {
  const size_t n = lower.size();
  for (size_t i = 0; i < n; ++i) {
    const size_t j = (i + 1) % n;
    AddQuad(mesh, lower[i], lower[j], upper[j], upper[i], group);
  }
}

// Axis-aligned box [-hx, hx] x [-hy, hy] x [0, h], one group per face.
ClosedMesh BoxMesh(float hx, float hy, float h) {
  ClosedMesh mesh;
  for (int i = 0; i < 8; ++i)
    AddVertex(&mesh, (i & 1) ? hx : -hx, (i & 2) ? hy : -hy, (i & 4) ? h : 0.f);
  // Corner i has x from bit 0, y from bit 1, z from bit 2.
  AddQuad(&mesh, 0, 2, 3, 1, 0);  // -z
  AddQuad(&mesh, 4, 5, 7, 6, 1);  // +z
  AddQuad(&mesh, 0, 1, 5, 4, 2);  // -y
  AddQuad(&mesh, 2, 6, 7, 3, 3);  // +y
  AddQuad(&mesh, 0, 4, 6, 2, 4);  // -x
  AddQuad(&mesh, 1, 3, 7, 5, 5);  // +x
  return mesh;
}

// Ring of `n` vertices at height z, radius (rx, ry), counter-clockwise seen
// from above.
std::vector<uint32_t> AddRing(ClosedMesh* mesh, int n, float rx, float ry, float z) {
  std::vector<uint32_t> ring;
  for (int i = 0; i < n; ++i) {
    const double angle = 2.0 * M_PI * i / n;
    ring.push_back(AddVertex(mesh, rx * static_cast<float>(std::cos(angle)),
                             ry * static_cast<float>(std::sin(angle)), z));
  }
  return ring;
}

ClosedMesh CylinderMesh(float radius, float height, int segments) {
  ClosedMesh mesh;
  const std::vector<uint32_t> bottom = AddRing(&mesh, segments, radius, radius, 0.f);
  const std::vector<uint32_t> top = AddRing(&mesh, segments, radius, radius, height);
  AddBand(&mesh, bottom, top, 0);
  AddFan(&mesh, AddVertex(&mesh, 0.f, 0.f, 0.f), bottom, false, 1);
  AddFan(&mesh, AddVertex(&mesh, 0.f, 0.f, height), top, true, 2);
  return mesh;
}

ClosedMesh EllipsoidMesh(float radius, float height, int segments) {
  ClosedMesh mesh;
  const int rings = std::max(2, segments / 2);  // latitude bands
  const float half = 0.5f * height;
  std::vector<std::vector<uint32_t>> latitude;
  for (int k = 1; k < rings; ++k) {
    const double theta = -0.5 * M_PI + M_PI * k / rings;
    const auto scale = static_cast<float>(std::cos(theta));
    latitude.push_back(AddRing(&mesh, segments, radius * scale, radius * scale,
                               half + half * static_cast<float>(std::sin(theta))));
  }
  for (size_t k = 0; k + 1 < latitude.size(); ++k) AddBand(&mesh, latitude[k], latitude[k + 1], 0);
  AddFan(&mesh, AddVertex(&mesh, 0.f, 0.f, 0.f), latitude.front(), false, 0);
  AddFan(&mesh, AddVertex(&mesh, 0.f, 0.f, height), latitude.back(), true, 0);
  return mesh;
}

}  // namespace

void ClosedMesh::Transform(const Eigen::Affine3f& transform) {
  for (Eigen::Vector3f& p : positions) p = transform * p;
}

void ClosedMesh::Append(const ClosedMesh& other) {
  const auto offset = static_cast<uint32_t>(positions.size());
  positions.insert(positions.end(), other.positions.begin(), other.positions.end());
  for (const std::array<uint32_t, 3>& t : other.triangles)
    triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  groups.insert(groups.end(), other.groups.begin(), other.groups.end());
}

ShadedMesh Shade(const ClosedMesh& mesh) {
  ShadedMesh shaded;
  // One shaded vertex per (vertex, group); its normal is the area-weighted
  // sum of the normals of the group's triangles around it.
  std::unordered_map<uint64_t, uint32_t> index_of;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::array<uint32_t, 3>& triangle = mesh.triangles[t];
    const Eigen::Vector3f& a = mesh.positions[triangle[0]];
    const Eigen::Vector3f normal =
        (mesh.positions[triangle[1]] - a).cross(mesh.positions[triangle[2]] - a);
    for (const uint32_t v : triangle) {
      const uint64_t key = (static_cast<uint64_t>(v) << 8) | mesh.groups[t];
      auto [it, added] = index_of.emplace(key, static_cast<uint32_t>(shaded.positions.size()));
      if (added) {
        shaded.positions.push_back(mesh.positions[v]);
        shaded.normals.push_back(Eigen::Vector3f::Zero());
      }
      shaded.normals[it->second] += normal;
      shaded.indices.push_back(it->second);
    }
  }
  for (Eigen::Vector3f& n : shaded.normals) {
    const float length = n.norm();
    n = length > 0.f ? Eigen::Vector3f(n / length) : Eigen::Vector3f::UnitZ();
  }
  return shaded;
}

ClosedMesh ShapeMesh(ObjectShape shape, double diameter_m, double height_m, int segments) {
  segments = std::max(segments, 3);
  const float diameter = std::max(static_cast<float>(diameter_m), kMinSizeM);
  const float height = std::max(static_cast<float>(height_m), kMinSizeM);
  switch (shape) {
    case ObjectShape::kBox: {
      const float half_side = 0.5f * diameter / std::sqrt(2.f);
      return BoxMesh(half_side, half_side, height);
    }
    case ObjectShape::kPanel: {
      // A door or a board: about 4 % as thick as it is wide (4 cm for a 1 m
      // door), its diagonal the diameter.
      const float thickness = std::max(0.04f * diameter, kMinSizeM);
      const float width =
          std::sqrt(std::max(diameter * diameter - thickness * thickness, kMinSizeM * kMinSizeM));
      return BoxMesh(0.5f * thickness, 0.5f * width, height);
    }
    case ObjectShape::kSphere:
      return EllipsoidMesh(0.5f * diameter, height, segments);
    case ObjectShape::kCylinder:
      break;
  }
  return CylinderMesh(0.5f * diameter, height, segments);
}

ClosedMesh TubeMesh(const std::vector<Eigen::Vector2d>& points, double z_m, double radius_m,
                    int sides) {
  ClosedMesh mesh;
  std::vector<Eigen::Vector2d> path;
  for (const Eigen::Vector2d& p : points)
    if (path.empty() || (p - path.back()).norm() > 1e-6) path.push_back(p);
  if (path.size() < 2) return mesh;
  sides = std::max(sides, 3);
  const auto radius = static_cast<float>(radius_m);
  std::vector<std::vector<uint32_t>> rings;
  for (size_t i = 0; i < path.size(); ++i) {
    const Eigen::Vector2d in = (path[i] - path[i == 0 ? 0 : i - 1]).normalized();
    const Eigen::Vector2d out = (path[std::min(i + 1, path.size() - 1)] - path[i]).normalized();
    const Eigen::Vector2d incoming = i == 0 ? out : in;
    const Eigen::Vector2d outgoing = i + 1 == path.size() ? in : out;
    // The ring lies in the plane bisecting the corner and is widened so the
    // tube keeps its radius there; a near-reversal keeps a plain ring.
    Eigen::Vector2d tangent = incoming + outgoing;
    double widen = 1.0;
    if (tangent.norm() < 1e-3) {
      tangent = incoming;
    } else {
      tangent.normalize();
      widen = std::min(3.0, 1.0 / std::max(1e-3, tangent.dot(outgoing)));
    }
    const Eigen::Vector3f side(static_cast<float>(-tangent.y() * widen),
                               static_cast<float>(tangent.x() * widen), 0.f);
    const Eigen::Vector3f centre(static_cast<float>(path[i].x()), static_cast<float>(path[i].y()),
                                 static_cast<float>(z_m));
    std::vector<uint32_t> ring;
    // Counter-clockwise about the direction of travel.
    for (int j = 0; j < sides; ++j) {
      const double angle = 2.0 * M_PI * j / sides;
      const Eigen::Vector3f p =
          centre + radius * (static_cast<float>(std::cos(angle)) * side +
                             static_cast<float>(std::sin(angle)) * Eigen::Vector3f::UnitZ());
      ring.push_back(AddVertex(&mesh, p.x(), p.y(), p.z()));
    }
    rings.push_back(std::move(ring));
  }
  for (size_t i = 0; i + 1 < rings.size(); ++i) AddBand(&mesh, rings[i], rings[i + 1], 0);
  const Eigen::Vector2d& first = path.front();
  const Eigen::Vector2d& last = path.back();
  AddFan(&mesh,
         AddVertex(&mesh, static_cast<float>(first.x()), static_cast<float>(first.y()),
                   static_cast<float>(z_m)),
         rings.front(), false, 1);
  AddFan(&mesh,
         AddVertex(&mesh, static_cast<float>(last.x()), static_cast<float>(last.y()),
                   static_cast<float>(z_m)),
         rings.back(), true, 2);
  return mesh;
}

ClosedMesh PyramidMesh(double length_m) {
  ClosedMesh mesh;
  const auto length = static_cast<float>(length_m), half = 0.5f * length;
  const uint32_t apex = AddVertex(&mesh, 0.f, 0.f, 0.f);
  // Base corners counter-clockwise seen from +x (outside the base).
  const std::vector<uint32_t> base = {
      AddVertex(&mesh, length, -half, -half), AddVertex(&mesh, length, half, -half),
      AddVertex(&mesh, length, half, half), AddVertex(&mesh, length, -half, half)};
  AddQuad(&mesh, base[0], base[1], base[2], base[3], 0);
  for (size_t k = 0; k < 4; ++k)
    AddTriangle(&mesh, apex, base[(k + 1) % 4], base[k], static_cast<uint8_t>(k + 1));
  return mesh;
}

}  // namespace oslam
