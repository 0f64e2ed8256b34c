// PLY export: written in both encodings, read back with PCL, counts and
// per-vertex colours (alpha = pi) checked.
#include "export/ply_writer.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include "export/export_fixture.h"
#include "test_util.h"

namespace oslam {
namespace {

class PlyEncodings : public ::testing::TestWithParam<PlyEncoding> {};

TEST_P(PlyEncodings, MeshReadsBackWithCountsAndColours) {
  testing::TempDir dir;
  const ExportScene scene = testing::FixtureScene();
  ExportOptions options;
  options.min_existence = 0.1;  // the door (pi = 0.05) is left out
  options.cylinder_segments = 16;
  WritePlyMesh(scene, options, dir.Path("map.ply"), GetParam());

  pcl::PolygonMesh mesh;
  ASSERT_EQ(pcl::io::loadPLYFile(dir.Path("map.ply"), mesh), 0);
  pcl::PointCloud<pcl::PointXYZRGBA> cloud;
  pcl::fromPCLPointCloud2(mesh.cloud, cloud);
  // Per cylinder: 2 side rings + 2 caps (centre + ring) = 4 * 16 + 2 vertices,
  // 2 * 16 side + 2 * 16 cap triangles.
  const size_t per_object_vertices = 4 * 16 + 2, per_object_faces = 4 * 16;
  ASSERT_EQ(cloud.size(), 2 * per_object_vertices);
  ASSERT_EQ(mesh.polygons.size(), 2 * per_object_faces);
  for (const pcl::Vertices& face : mesh.polygons) {
    ASSERT_EQ(face.vertices.size(), 3u);
    for (const auto v : face.vertices) EXPECT_LT(static_cast<size_t>(v), cloud.size());
  }
  for (size_t i = 0; i < cloud.size(); ++i) {
    const bool first = i < per_object_vertices;
    const pcl::PointXYZRGBA& p = cloud[i];
    const Rgb expected = first ? Rgb{40, 150, 60} : Rgb{240, 110, 170};
    EXPECT_EQ(p.r, expected[0]);
    EXPECT_EQ(p.g, expected[1]);
    EXPECT_EQ(p.b, expected[2]);
    EXPECT_EQ(p.a, first ? 255 : 153);  // round(255 * 0.6)
    // Z up, as in the map: within the object's cylinder.
    const OMapObject& object = scene.map.objects[first ? 0 : 1];
    EXPECT_LE(std::hypot(p.x - object.base_world.x(), p.y - object.base_world.y()),
              0.5 * object.diameter_m + 1e-5);
    EXPECT_GE(p.z, object.base_world.z() - 1e-5);
    EXPECT_LE(p.z, object.base_world.z() + object.height_m + 1e-5);
  }
}

TEST_P(PlyEncodings, TrajectoriesReadBackAsColouredPoints) {
  testing::TempDir dir;
  const ExportScene scene = testing::FixtureScene();
  WritePlyTrajectories(scene, dir.Path("trajectory.ply"), GetParam());
  pcl::PointCloud<pcl::PointXYZRGBA> cloud;
  ASSERT_EQ(pcl::io::loadPLYFile(dir.Path("trajectory.ply"), cloud), 0);
  const size_t n = scene.ground_truth.size();
  ASSERT_EQ(cloud.size(), 3 * n);
  // Estimated (black), odometry (red), ground truth (green), in frame order.
  EXPECT_EQ(cloud[0].r + cloud[0].g + cloud[0].b, 0);
  EXPECT_EQ(cloud[n].r, 210);
  EXPECT_EQ(cloud[2 * n].g, 150);
  // Float coordinates, ASCII with 7 significant digits: 10 um is plenty.
  EXPECT_NEAR(cloud[2 * n + 5].x, scene.ground_truth[5].x, 1e-5);
  EXPECT_NEAR(cloud[2 * n + 5].y, scene.ground_truth[5].y, 1e-5);
}

INSTANTIATE_TEST_SUITE_P(Export, PlyEncodings,
                         ::testing::Values(PlyEncoding::kAscii, PlyEncoding::kBinary),
                         [](const auto& info) {
                           return info.param == PlyEncoding::kAscii ? "ascii" : "binary";
                         });

// MeshLab reads vertex alpha from a "uchar alpha" property.
TEST(PlyWriter, HeaderDeclaresRgbaAndTriangles) {
  testing::TempDir dir;
  WritePlyMesh(testing::FixtureScene(), ExportOptions{}, dir.Path("map.ply"), PlyEncoding::kAscii);
  std::ifstream in(dir.Path("map.ply"));
  std::string header, line;
  while (std::getline(in, line) && line != "end_header") header += line + "\n";
  for (const char* expected :
       {"format ascii 1.0", "property uchar red", "property uchar green", "property uchar blue",
        "property uchar alpha", "element face", "vertex_indices"})
    EXPECT_NE(header.find(expected), std::string::npos) << expected << "\n" << header;
}

}  // namespace
}  // namespace oslam
