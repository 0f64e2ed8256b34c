// The display meshes: every shape closed and consistently wound outwards
// (positive enclosed volume, close to the solid's), sized as documented; the
// tube closed around a path with corners, stops and a reversal; shading
// splits vertices only between groups.
#include "export/shape_mesh.h"

#include <cmath>

#include <gtest/gtest.h>

#include "export/mesh_check.h"

namespace oslam {
namespace {

double Volume(const ClosedMesh& mesh) {
  double volume = 0.0;
  for (const auto& t : mesh.triangles)
    volume += mesh.positions[t[0]].cast<double>().dot(
                  mesh.positions[t[1]].cast<double>().cross(mesh.positions[t[2]].cast<double>())) /
              6.0;
  return volume;
}

void ExpectClosed(const ClosedMesh& mesh, const std::string& what) {
  ASSERT_EQ(mesh.groups.size(), mesh.triangles.size()) << what;
  const testing::Topology topology =
      testing::AnalyzeTopology(mesh.positions.size(), mesh.triangles);
  EXPECT_EQ(topology.components, 1) << what;
  EXPECT_TRUE(topology.Watertight()) << what << ": " << topology.boundary_edges << " boundary, "
                                     << topology.non_manifold_edges << " non-manifold edges";
  EXPECT_EQ(topology.inconsistent_edges, 0) << what;
  EXPECT_EQ(topology.unreferenced_vertices, 0) << what;
  EXPECT_GT(Volume(mesh), 0.0) << what << " is inside out";
}

TEST(ShapeMesh, EveryShapeIsClosedWithTheSolidsVolume) {
  const double d = 0.6, h = 0.5, r = 0.3;
  const int n = 64;
  const double polygon = n / (2.0 * M_PI) * std::sin(2.0 * M_PI / n);  // n-gon / circle area
  struct Case {
    ObjectShape shape;
    double volume;
    double tolerance;
  };
  for (const Case& c :
       {Case{ObjectShape::kCylinder, M_PI * r * r * h * polygon, 1e-6},
        Case{ObjectShape::kBox, 0.5 * d * d * h, 1e-6},
        Case{ObjectShape::kSphere, 4.0 / 3.0 * M_PI * r * r * 0.5 * h, 0.01},
        Case{ObjectShape::kPanel, 0.04 * d * std::sqrt(d * d - 0.04 * 0.04 * d * d) * h, 1e-6}}) {
    const ClosedMesh mesh = ShapeMesh(c.shape, d, h, n);
    ExpectClosed(mesh, ObjectShapeName(c.shape));
    EXPECT_NEAR(Volume(mesh), c.volume, c.tolerance * c.volume) << ObjectShapeName(c.shape);
    float low = 1e9f, high = -1e9f, widest = 0.f;
    for (const Eigen::Vector3f& p : mesh.positions) {
      low = std::min(low, p.z());
      high = std::max(high, p.z());
      widest = std::max(widest, std::hypot(p.x(), p.y()));
    }
    EXPECT_NEAR(low, 0.0, 1e-6) << ObjectShapeName(c.shape);
    EXPECT_NEAR(high, h, 1e-6) << ObjectShapeName(c.shape);
    EXPECT_NEAR(widest, 0.5 * d, 1e-6) << ObjectShapeName(c.shape);
  }
}

TEST(ShapeMesh, TinySizesStayNonDegenerate) {
  for (const ObjectShape shape :
       {ObjectShape::kCylinder, ObjectShape::kBox, ObjectShape::kSphere, ObjectShape::kPanel}) {
    const ClosedMesh mesh = ShapeMesh(shape, 0.0, 0.0, 8);
    ExpectClosed(mesh, ObjectShapeName(shape));
  }
}

TEST(ShapeMesh, TubeIsClosedAroundCornersStopsAndReversals) {
  // A square path with a repeated point (the robot stopped) and a turn back.
  const std::vector<Eigen::Vector2d> path = {{0, 0}, {1, 0},   {1, 0},   {1, 1},
                                             {0, 1}, {0.5, 1}, {0.8, 1}, {0, 0}};
  const ClosedMesh tube = TubeMesh(path, 0.05, 0.02, 8);
  ExpectClosed(tube, "tube");
  // 7 distinct points, 8 vertices each, 2 cap centres.
  EXPECT_EQ(tube.positions.size(), 7u * 8u + 2u);
  for (const Eigen::Vector3f& p : tube.positions) {
    EXPECT_GE(p.z(), 0.05f - 0.02f - 1e-6f);
    EXPECT_LE(p.z(), 0.05f + 0.02f + 1e-6f);
  }
  EXPECT_TRUE(TubeMesh({{1, 1}, {1, 1}}, 0.0, 0.01, 8).positions.empty());
}

TEST(ShapeMesh, PyramidIsClosedAndOpensAlongX) {
  const ClosedMesh pyramid = PyramidMesh(0.2);
  ExpectClosed(pyramid, "pyramid");
  EXPECT_NEAR(Volume(pyramid), 0.2 * 0.2 * 0.2 / 3.0, 1e-7);
  for (const Eigen::Vector3f& p : pyramid.positions) EXPECT_GE(p.x(), 0.0f);
}

// A box shades flat (4 vertices per face), a sphere smooth (one vertex per
// position), a cylinder smooth around the side and flat on the caps.
TEST(ShapeMesh, ShadingSplitsVerticesBetweenGroupsOnly) {
  const ShadedMesh box = Shade(ShapeMesh(ObjectShape::kBox, 1.0, 1.0, 16));
  EXPECT_EQ(box.positions.size(), 24u);
  const ClosedMesh sphere_mesh = ShapeMesh(ObjectShape::kSphere, 1.0, 1.0, 16);
  const ShadedMesh sphere = Shade(sphere_mesh);
  EXPECT_EQ(sphere.positions.size(), sphere_mesh.positions.size());
  const ShadedMesh cylinder = Shade(ShapeMesh(ObjectShape::kCylinder, 1.0, 1.0, 16));
  EXPECT_EQ(cylinder.positions.size(), 2u * 16u + 2u * 17u);
  for (const ShadedMesh* mesh : {&box, &sphere, &cylinder})
    for (const Eigen::Vector3f& normal : mesh->normals) EXPECT_NEAR(normal.norm(), 1.0f, 1e-5f);
}

TEST(ObjectShape, NamesRoundTrip) {
  for (const ObjectShape shape :
       {ObjectShape::kCylinder, ObjectShape::kBox, ObjectShape::kSphere, ObjectShape::kPanel})
    EXPECT_EQ(ParseObjectShape(ObjectShapeName(shape)), shape);
  EXPECT_FALSE(ParseObjectShape("cone").has_value());
}

}  // namespace
}  // namespace oslam
