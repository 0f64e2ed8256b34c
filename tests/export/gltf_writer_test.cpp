// glTF export: written, re-loaded with tinygltf, and checked for content
// (names, geometry in Y up, materials, extras) and structural validity.
#include "export/gltf_writer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <Eigen/Geometry>

#include "export/display_scene.h"
#include "export/export_fixture.h"
#include "export/mesh_check.h"
#include "test_util.h"

namespace oslam {
namespace {

tinygltf::Model Load(const std::string& path) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string error, warning;
  const bool binary = path.substr(path.size() - 4) == ".glb";
  const bool ok = binary ? loader.LoadBinaryFromFile(&model, &error, &warning, path)
                         : loader.LoadASCIIFromFile(&model, &error, &warning, path);
  EXPECT_TRUE(ok) << error;
  EXPECT_EQ(error, "");
  EXPECT_EQ(warning, "");
  return model;
}

std::vector<Eigen::Vector3f> ReadVec3(const tinygltf::Model& model, int accessor_index) {
  const tinygltf::Accessor& accessor = model.accessors.at(accessor_index);
  EXPECT_EQ(accessor.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
  EXPECT_EQ(accessor.type, TINYGLTF_TYPE_VEC3);
  const tinygltf::BufferView& view = model.bufferViews.at(accessor.bufferView);
  const unsigned char* data =
      model.buffers.at(view.buffer).data.data() + view.byteOffset + accessor.byteOffset;
  std::vector<Eigen::Vector3f> values(accessor.count);
  for (size_t i = 0; i < accessor.count; ++i) std::memcpy(values[i].data(), data + 12 * i, 12);
  return values;
}

std::vector<uint32_t> ReadIndices(const tinygltf::Model& model, int accessor_index) {
  const tinygltf::Accessor& accessor = model.accessors.at(accessor_index);
  EXPECT_EQ(accessor.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
  const tinygltf::BufferView& view = model.bufferViews.at(accessor.bufferView);
  std::vector<uint32_t> values(accessor.count);
  std::memcpy(values.data(), model.buffers.at(view.buffer).data.data() + view.byteOffset,
              4 * accessor.count);
  return values;
}

const tinygltf::Node* FindNode(const tinygltf::Model& model, const std::string& name) {
  for (const tinygltf::Node& node : model.nodes)
    if (node.name == name) return &node;
  return nullptr;
}

std::string WriteFixture(const testing::TempDir& dir, const std::string& name,
                         double min_existence = 0.1) {
  ExportOptions options;
  options.min_existence = min_existence;
  const std::string path = dir.Path(name);
  WriteGltf(testing::FixtureScene(), options, path);
  return path;
}

class GltfFormats : public ::testing::TestWithParam<std::string> {};

TEST_P(GltfFormats, NodesAreTheShownObjectsTrajectoriesAndFloor) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam()));
  std::vector<std::string> names;
  for (const tinygltf::Node& node : model.nodes) names.push_back(node.name);
  // The door (pi = 0.05) is below min_existence = 0.1 and left out.
  EXPECT_EQ(names, (std::vector<std::string>{"green box 1", "pink ball 2", "Magellan 4",
                                             "trajectory estimated", "trajectory odometry",
                                             "trajectory ground truth", "floor", "floor grid"}));
  ASSERT_EQ(model.scenes.size(), 1u);
  EXPECT_EQ(model.scenes[0].nodes.size(), model.nodes.size());
  EXPECT_EQ(model.asset.version, "2.0");
  // Every node is a triangle mesh: nothing a viewer would import as loose
  // lines or points.
  for (const tinygltf::Mesh& mesh : model.meshes)
    for (const tinygltf::Primitive& primitive : mesh.primitives)
      EXPECT_EQ(primitive.mode, TINYGLTF_MODE_TRIANGLES) << mesh.name;
}

// Each shape's extent in glTF's Y-up frame (x -> x, z -> y, y -> -z): its
// height from the base point up, and no wider than the diameter, which the
// box's corners, the cylinder's and the sphere's equator reach.
TEST_P(GltfFormats, ObjectsHaveTheirClassShapeAndSize) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam()));
  const ExportScene scene = testing::FixtureScene();
  for (const int j : {0, 1, 3}) {
    const OMapObject& object = scene.map.objects[j];
    const tinygltf::Node* node = FindNode(model, ObjectLabel(object));
    ASSERT_NE(node, nullptr);
    const tinygltf::Primitive& primitive = model.meshes.at(node->mesh).primitives.at(0);
    const std::vector<Eigen::Vector3f> positions =
        ReadVec3(model, primitive.attributes.at("POSITION"));
    ASSERT_EQ(node->translation.size(), 3u);
    const Eigen::Vector3d& b = object.base_world;
    EXPECT_NEAR(node->translation[0], b.x(), 1e-6);
    EXPECT_NEAR(node->translation[1], b.z(), 1e-6);
    EXPECT_NEAR(node->translation[2], -b.y(), 1e-6);
    float low = 1e9f, high = -1e9f, widest = 0.f;
    for (const Eigen::Vector3f& p : positions) {
      low = std::min(low, p.y());
      high = std::max(high, p.y());
      widest = std::max(widest, std::hypot(p.x(), p.z()));
    }
    EXPECT_NEAR(low, 0.0, 1e-6) << object.class_name;
    EXPECT_NEAR(high, object.height_m, 1e-5) << object.class_name;
    EXPECT_NEAR(widest, 0.5 * object.diameter_m, 1e-5) << object.class_name;
    size_t distinct = 0;
    testing::WeldByPosition(positions, ReadIndices(model, primitive.indices), &distinct);
    if (j == 0) {
      EXPECT_EQ(distinct, 8u) << "a box has 8 corners";
    }
    EXPECT_EQ(node->extras.Get("shape").Get<std::string>(),
              std::vector<std::string>({"box", "sphere", "", "cylinder"})[j]);
  }
}

// Closed meshes: no see-through caps or gaps, whatever a viewer culls.
TEST_P(GltfFormats, ObjectAndTrajectoryMeshesAreClosed) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam()));
  for (const char* name : {"green box 1", "pink ball 2", "Magellan 4", "trajectory estimated",
                           "trajectory odometry", "trajectory ground truth"}) {
    const tinygltf::Node* node = FindNode(model, name);
    ASSERT_NE(node, nullptr) << name;
    const tinygltf::Primitive& primitive = model.meshes.at(node->mesh).primitives.at(0);
    size_t distinct = 0;
    const auto triangles =
        testing::WeldByPosition(ReadVec3(model, primitive.attributes.at("POSITION")),
                                ReadIndices(model, primitive.indices), &distinct);
    const testing::Topology topology = testing::AnalyzeTopology(distinct, triangles);
    EXPECT_EQ(topology.components, 1) << name;
    EXPECT_TRUE(topology.Watertight())
        << name << ": " << topology.boundary_edges << " boundary edges";
    EXPECT_EQ(topology.inconsistent_edges, 0) << name;
  }
}

TEST_P(GltfFormats, NormalsAreUnitAndPointOutwards) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam()));
  const ExportScene scene = testing::FixtureScene();
  for (const int j : {0, 1, 3}) {
    const OMapObject& object = scene.map.objects[j];
    const tinygltf::Node* node = FindNode(model, ObjectLabel(object));
    ASSERT_NE(node, nullptr);
    const tinygltf::Primitive& primitive = model.meshes.at(node->mesh).primitives.at(0);
    const auto positions = ReadVec3(model, primitive.attributes.at("POSITION"));
    const auto normals = ReadVec3(model, primitive.attributes.at("NORMAL"));
    ASSERT_EQ(normals.size(), positions.size());
    // Local axis is +y, base at y = 0; every shape is convex around its centre.
    const Eigen::Vector3f centre(0, 0.5f * static_cast<float>(object.height_m), 0);
    for (size_t i = 0; i < normals.size(); ++i) {
      EXPECT_NEAR(normals[i].norm(), 1.0f, 1e-5);
      EXPECT_GT(normals[i].dot(positions[i] - centre), 0.0f) << object.class_name << " " << i;
    }
    // Counter-clockwise winding seen from outside: each face normal agrees
    // with its vertex normals (what viewers use for back-face culling).
    const std::vector<uint32_t> indices = ReadIndices(model, primitive.indices);
    for (size_t t = 0; t + 2 < indices.size(); t += 3) {
      const Eigen::Vector3f a = positions[indices[t]], b = positions[indices[t + 1]],
                            c = positions[indices[t + 2]];
      EXPECT_GT((b - a).cross(c - a).dot(normals[indices[t]]), 0.0f)
          << object.class_name << " triangle " << t / 3;
    }
  }
}

TEST_P(GltfFormats, MaterialIsClassColourWithAlphaPiAndSingleSided) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam()));
  const tinygltf::Node* node = FindNode(model, "pink ball 2");
  ASSERT_NE(node, nullptr);
  const tinygltf::Material& material =
      model.materials.at(model.meshes.at(node->mesh).primitives.at(0).material);
  EXPECT_EQ(material.alphaMode, "BLEND");
  // Closed meshes, back faces culled: no inner face shows through.
  EXPECT_FALSE(material.doubleSided);
  const std::vector<double>& colour = material.pbrMetallicRoughness.baseColorFactor;
  ASSERT_EQ(colour.size(), 4u);
  EXPECT_NEAR(colour[0], SrgbToLinear(240), 1e-9);
  EXPECT_NEAR(colour[1], SrgbToLinear(110), 1e-9);
  EXPECT_NEAR(colour[2], SrgbToLinear(170), 1e-9);
  EXPECT_NEAR(colour[3], 0.6, 1e-12);
}

TEST_P(GltfFormats, ExtrasCarryPiHistogramAndCovariance) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam()));
  const tinygltf::Node* node = FindNode(model, "pink ball 2");
  ASSERT_NE(node, nullptr);
  const tinygltf::Value& extras = node->extras;
  ASSERT_TRUE(extras.IsObject());
  EXPECT_NEAR(extras.Get("existence_probability").GetNumberAsDouble(), 0.6, 1e-12);
  EXPECT_NEAR(extras.Get("class_histogram").Get("pink ball").GetNumberAsDouble(), 0.9, 1e-12);
  EXPECT_NEAR(extras.Get("class_histogram").Get("other").GetNumberAsDouble(), 0.1, 1e-12);
  const tinygltf::Value& covariance = extras.Get("covariance");
  ASSERT_EQ(covariance.ArrayLen(), 5u);
  EXPECT_NEAR(covariance.Get(4).Get(4).GetNumberAsDouble(), 0.05, 1e-12);
  EXPECT_NEAR(covariance.Get(0).Get(1).GetNumberAsDouble(), 0.002, 1e-12);
  EXPECT_EQ(extras.Get("num_detections").GetNumberAsInt(), 20);
}

// A tube of the display radius around the ground-truth path, at its height,
// in an opaque material named after it.
TEST_P(GltfFormats, TrajectoryIsANamedTubeAlongThePath) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam()));
  const tinygltf::Node* node = FindNode(model, "trajectory ground truth");
  ASSERT_NE(node, nullptr);
  const tinygltf::Primitive& primitive = model.meshes.at(node->mesh).primitives.at(0);
  const tinygltf::Material& material = model.materials.at(primitive.material);
  EXPECT_EQ(material.name, "trajectory ground truth");
  EXPECT_EQ(material.alphaMode, "OPAQUE");
  ExportOptions options;
  options.min_existence = 0.1;
  const ExportScene scene = testing::FixtureScene();
  const DisplayScene display = BuildDisplayScene(scene, options);
  const double r = display.tube_radius_m, z = display.trajectories[2].z_m;
  const std::vector<Pose2>& truth = scene.ground_truth;
  for (const Eigen::Vector3f& p : ReadVec3(model, primitive.attributes.at("POSITION"))) {
    EXPECT_GE(p.y(), z - r - 1e-6);
    EXPECT_LE(p.y(), z + r + 1e-6);
    // Distance to the path on the floor (x, -z in glTF).
    double nearest = 1e9;
    for (size_t i = 0; i + 1 < truth.size(); ++i) {
      const Eigen::Vector2d a(truth[i].x, truth[i].y), b(truth[i + 1].x, truth[i + 1].y);
      const Eigen::Vector2d q(p.x(), -p.z());
      const double t = std::clamp((q - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      nearest = std::min(nearest, (q - (a + t * (b - a))).norm());
    }
    EXPECT_LE(nearest, 1.5 * r);
  }
}

TEST_P(GltfFormats, FloorCoversTheMapAndCamerasAreOptional) {
  testing::TempDir dir;
  ExportOptions options;
  options.min_existence = 0.1;
  options.camera_every = 6;
  const ExportScene scene = testing::FixtureScene();
  WriteGltf(scene, options, dir.Path("map" + GetParam()));
  const tinygltf::Model model = Load(dir.Path("map" + GetParam()));
  const tinygltf::Node* floor = FindNode(model, "floor");
  ASSERT_NE(floor, nullptr);
  const Eigen::Vector4d extent = FloorExtent(scene, 0.1, 0.5);
  const auto corners =
      ReadVec3(model, model.meshes.at(floor->mesh).primitives.at(0).attributes.at("POSITION"));
  float x_low = 1e9f, x_high = -1e9f;
  for (const Eigen::Vector3f& p : corners) {
    EXPECT_EQ(p.y(), 0.0f);
    x_low = std::min(x_low, p.x());
    x_high = std::max(x_high, p.x());
  }
  EXPECT_NEAR(x_low, extent[0], 1e-6);
  EXPECT_NEAR(x_high, extent[2], 1e-6);
  const tinygltf::Node* cameras = FindNode(model, "cameras");
  ASSERT_NE(cameras, nullptr);
  size_t distinct = 0;
  const tinygltf::Primitive& primitive = model.meshes.at(cameras->mesh).primitives.at(0);
  const auto triangles =
      testing::WeldByPosition(ReadVec3(model, primitive.attributes.at("POSITION")),
                              ReadIndices(model, primitive.indices), &distinct);
  // 24 poses, every 6th: 4 pyramids of 5 corners.
  EXPECT_EQ(testing::AnalyzeTopology(distinct, triangles).components, 4);
  EXPECT_EQ(distinct, 20u);
  EXPECT_EQ(FindNode(Load(WriteFixture(dir, "plain" + GetParam())), "cameras"), nullptr);
}

// What the Khronos validator checks first: every accessor fits its buffer
// view, views fit the buffer, offsets are aligned, POSITION min/max match the
// data, indices stay within the vertex count.
TEST_P(GltfFormats, AccessorsAndBuffersAreConsistent) {
  testing::TempDir dir;
  const tinygltf::Model model = Load(WriteFixture(dir, "map" + GetParam(), 0.0));
  ASSERT_EQ(model.buffers.size(), 1u);
  for (const tinygltf::BufferView& view : model.bufferViews) {
    EXPECT_EQ(view.byteOffset % 4, 0u);
    EXPECT_LE(view.byteOffset + view.byteLength, model.buffers[0].data.size());
  }
  for (const tinygltf::Mesh& mesh : model.meshes) {
    for (const tinygltf::Primitive& primitive : mesh.primitives) {
      const int position_accessor = primitive.attributes.at("POSITION");
      const auto positions = ReadVec3(model, position_accessor);
      const tinygltf::Accessor& accessor = model.accessors[position_accessor];
      EXPECT_EQ(accessor.bufferView >= 0 &&
                    12 * accessor.count <= model.bufferViews[accessor.bufferView].byteLength,
                true);
      ASSERT_EQ(accessor.minValues.size(), 3u);
      ASSERT_EQ(accessor.maxValues.size(), 3u);
      for (int k = 0; k < 3; ++k) {
        float low = 1e30f, high = -1e30f;
        for (const auto& p : positions) {
          low = std::min(low, p[k]);
          high = std::max(high, p[k]);
        }
        EXPECT_EQ(static_cast<float>(accessor.minValues[k]), low) << mesh.name;
        EXPECT_EQ(static_cast<float>(accessor.maxValues[k]), high) << mesh.name;
      }
      if (primitive.indices >= 0) {
        for (const uint32_t index : ReadIndices(model, primitive.indices))
          EXPECT_LT(index, positions.size());
      }
    }
  }
  // min_existence 0: all three objects.
  EXPECT_NE(FindNode(model, "orange door 3"), nullptr);
}

INSTANTIATE_TEST_SUITE_P(Export, GltfFormats, ::testing::Values(".glb", ".gltf"),
                         [](const auto& info) { return info.param.substr(1); });

TEST(GltfWriter, GlbHasTheBinaryHeaderAndGltfIsSelfContainedJson) {
  testing::TempDir dir;
  std::ifstream glb(WriteFixture(dir, "map.glb"), std::ios::binary);
  char magic[4] = {};
  glb.read(magic, 4);
  EXPECT_EQ(std::string(magic, 4), "glTF");
  std::ifstream gltf(WriteFixture(dir, "map.gltf"));
  const std::string text((std::istreambuf_iterator<char>(gltf)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("data:application/octet-stream;base64,"), std::string::npos);
}

TEST(GltfWriter, EmptyMapWithoutGridIsTheFloorAlone) {
  testing::TempDir dir;
  ExportOptions options;
  options.floor_grid = false;
  WriteGltf(ExportScene{}, options, dir.Path("empty.glb"));
  const tinygltf::Model model = Load(dir.Path("empty.glb"));
  ASSERT_EQ(model.nodes.size(), 1u);
  EXPECT_EQ(model.nodes[0].name, "floor");
}

TEST(GltfWriter, UnwritablePathNamesTheFile) {
  testing::TempDir dir;
  std::ofstream(dir.Path("plain-file")) << "not a folder";
  const std::string path = dir.Path("plain-file/map.glb");
  try {
    WriteGltf(testing::FixtureScene(), ExportOptions{}, path);
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace oslam
