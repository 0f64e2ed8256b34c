// PLY export: written in both encodings, parsed back (tests/export/mesh_check.h)
// and checked as MeshLab would: one closed, watertight component per object,
// consistently wound, per-vertex RGBA (alpha = pi); trajectories as polylines
// of vertices and edges; a header of only what the data needs.
#include "export/ply_writer.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"
#include "export/export_fixture.h"
#include "export/mesh_check.h"
#include "test_util.h"

namespace oslam {
namespace {

class PlyEncodings : public ::testing::TestWithParam<PlyEncoding> {};

TEST_P(PlyEncodings, MapIsOneWatertightComponentPerObject) {
  testing::TempDir dir;
  const ExportScene scene = testing::FixtureScene();
  ExportOptions options;
  options.min_existence = 0.1;  // the door (pi = 0.05) is left out
  options.cylinder_segments = 16;
  WritePlyMesh(scene, options, dir.Path("map.ply"), GetParam());

  const testing::PlyFile ply = testing::ReadPly(dir.Path("map.ply"));
  ASSERT_EQ(ply.error, "");
  ASSERT_FALSE(ply.faces.empty());
  const testing::Topology topology = testing::AnalyzeTopology(ply.positions.size(), ply.faces);
  EXPECT_EQ(topology.components, 3);  // green box, pink ball, Magellan
  EXPECT_EQ(topology.boundary_edges, 0);
  EXPECT_EQ(topology.holes, 0);
  EXPECT_EQ(topology.non_manifold_edges, 0);
  EXPECT_EQ(topology.inconsistent_edges, 0);
  EXPECT_EQ(topology.unreferenced_vertices, 0);
  EXPECT_TRUE(topology.Watertight());
  // Closed meshes wound counter-clockwise seen from outside enclose a
  // positive volume (divergence theorem); inside-out ones a negative one.
  double volume = 0.0;
  for (const auto& f : ply.faces)
    volume += ply.positions[f[0]].cast<double>().dot(
                  ply.positions[f[1]].cast<double>().cross(ply.positions[f[2]].cast<double>())) /
              6.0;
  EXPECT_GT(volume, 0.0);

  // Box: 8 shared corners; ball: 16 x 7 rings + 2 poles; cylinder: 2 rings + 2 centres.
  ASSERT_EQ(ply.positions.size(), 8u + (16 * 7 + 2) + (2 * 16 + 2));
  for (size_t i = 0; i < ply.positions.size(); ++i) {
    const int o = i < 8 ? 0 : i < 8 + 114 ? 1 : 3;
    const OMapObject& object = scene.map.objects[o];
    const Rgb expected = ClassColour(scene.classes, object.class_name);
    EXPECT_EQ(ply.rgba[i][0], expected[0]) << i;
    EXPECT_EQ(ply.rgba[i][1], expected[1]) << i;
    EXPECT_EQ(ply.rgba[i][2], expected[2]) << i;
    EXPECT_EQ(ply.rgba[i][3], std::lround(255 * object.existence_probability)) << i;
    // Z up, as in the map: within the object's cylinder.
    const Eigen::Vector3f& p = ply.positions[i];
    EXPECT_LE(std::hypot(p.x() - object.base_world.x(), p.y() - object.base_world.y()),
              0.5 * object.diameter_m + 1e-5);
    EXPECT_GE(p.z(), object.base_world.z() - 1e-5);
    EXPECT_LE(p.z(), object.base_world.z() + object.height_m + 1e-5);
  }
}

TEST_P(PlyEncodings, TrajectoriesArePolylinesOfVerticesAndEdges) {
  testing::TempDir dir;
  const ExportScene scene = testing::FixtureScene();
  WritePlyTrajectories(scene, dir.Path("trajectory.ply"), GetParam());
  const testing::PlyFile ply = testing::ReadPly(dir.Path("trajectory.ply"));
  ASSERT_EQ(ply.error, "");
  const size_t n = scene.ground_truth.size();
  ASSERT_EQ(ply.positions.size(), 3 * n);
  ASSERT_EQ(ply.edges.size(), 3 * (n - 1));
  EXPECT_TRUE(ply.faces.empty());
  // Each edge joins consecutive poses of one trajectory.
  for (size_t t = 0; t < 3; ++t)
    for (size_t i = 0; i + 1 < n; ++i) {
      const auto& edge = ply.edges[t * (n - 1) + i];
      EXPECT_EQ(edge[0], t * n + i);
      EXPECT_EQ(edge[1], t * n + i + 1);
    }
  // Estimated (black), odometry (red), ground truth (green), in frame order.
  EXPECT_EQ(ply.rgba[0][0] + ply.rgba[0][1] + ply.rgba[0][2], 0);
  EXPECT_EQ(ply.rgba[n][0], 210);
  EXPECT_EQ(ply.rgba[2 * n][1], 150);
  EXPECT_NEAR(ply.positions[2 * n + 5].x(), scene.ground_truth[5].x, 1e-6);
  EXPECT_NEAR(ply.positions[2 * n + 5].y(), scene.ground_truth[5].y, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Export, PlyEncodings,
                         ::testing::Values(PlyEncoding::kAscii, PlyEncoding::kBinary),
                         [](const auto& info) {
                           return info.param == PlyEncoding::kAscii ? "ascii" : "binary";
                         });

// The whole header: format, one comment, the elements and properties the
// data has, nothing left over (no empty face element, no library comments).
TEST(PlyWriter, HeadersDeclareOnlyWhatTheDataHas) {
  testing::TempDir dir;
  WritePlyMesh(testing::FixtureScene(), ExportOptions{}, dir.Path("map.ply"), PlyEncoding::kAscii);
  WritePlyTrajectories(testing::FixtureScene(), dir.Path("trajectory.ply"), PlyEncoding::kBinary);
  const std::vector<std::string> vertex = {
      "property float x",     "property float y",    "property float z",    "property uchar red",
      "property uchar green", "property uchar blue", "property uchar alpha"};
  auto expected = [&](const std::string& format, const std::string& vertices,
                      const std::vector<std::string>& rest) {
    std::vector<std::string> lines = {"ply", "format " + format + " 1.0"};
    lines.push_back("");  // the comment, compared by prefix below
    lines.push_back("element vertex " + vertices);
    lines.insert(lines.end(), vertex.begin(), vertex.end());
    lines.insert(lines.end(), rest.begin(), rest.end());
    lines.push_back("end_header");
    return lines;
  };
  const testing::PlyFile map = testing::ReadPly(dir.Path("map.ply"));
  ASSERT_EQ(map.error, "");
  std::vector<std::string> map_header = map.header;
  ASSERT_GE(map_header.size(), 3u);
  EXPECT_EQ(map_header[2].rfind("comment oslam ", 0), 0u) << map_header[2];
  map_header[2] = "";
  EXPECT_EQ(map_header, expected("ascii", std::to_string(map.positions.size()),
                                 {"element face " + std::to_string(map.faces.size()),
                                  "property list uchar int vertex_indices"}));
  const testing::PlyFile trajectory = testing::ReadPly(dir.Path("trajectory.ply"));
  ASSERT_EQ(trajectory.error, "");
  std::vector<std::string> trajectory_header = trajectory.header;
  trajectory_header[2] = "";
  EXPECT_EQ(trajectory_header,
            expected("binary_little_endian", std::to_string(trajectory.positions.size()),
                     {"element edge " + std::to_string(trajectory.edges.size()),
                      "property int vertex1", "property int vertex2"}));
}

TEST(PlyWriter, EmptyMapIsAValidEmptyMesh) {
  testing::TempDir dir;
  WritePlyMesh(ExportScene{}, ExportOptions{}, dir.Path("map.ply"), PlyEncoding::kBinary);
  const testing::PlyFile ply = testing::ReadPly(dir.Path("map.ply"));
  EXPECT_EQ(ply.error, "");
  EXPECT_TRUE(ply.positions.empty());
  EXPECT_TRUE(ply.faces.empty());
  EXPECT_THROW(
      WritePlyTrajectories(ExportScene{}, dir.Path("trajectory.ply"), PlyEncoding::kBinary), Error);
}

}  // namespace
}  // namespace oslam
