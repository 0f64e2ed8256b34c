#include "export/gltf_writer.h"

#include <cmath>
#include <cstring>

#include <tiny_gltf.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "export/cylinder_mesh.h"

namespace oslam {
namespace {

// Appends typed arrays to the single buffer, each in its own 4-byte aligned
// buffer view with one accessor.
class BufferBuilder {
 public:
  explicit BufferBuilder(tinygltf::Model* model) : model_(model) { model_->buffers.emplace_back(); }

  int AddVec3(const std::vector<Eigen::Vector3f>& values, bool with_bounds) {
    std::vector<float> flat;
    flat.reserve(3 * values.size());
    for (const Eigen::Vector3f& v : values) flat.insert(flat.end(), {v.x(), v.y(), v.z()});
    const int accessor = AddAccessor(flat.data(), flat.size() * sizeof(float), values.size(),
                                     TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                     TINYGLTF_TARGET_ARRAY_BUFFER);
    if (with_bounds) SetBounds(values, &model_->accessors[accessor]);
    return accessor;
  }

  int AddIndices(const std::vector<uint32_t>& indices) {
    return AddAccessor(indices.data(), indices.size() * sizeof(uint32_t), indices.size(),
                       TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                       TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  }

 private:
  int AddAccessor(const void* data, size_t bytes, size_t count, int component_type, int type,
                  int target) {
    std::vector<unsigned char>& buffer = model_->buffers[0].data;
    while (buffer.size() % 4) buffer.push_back(0);  // glTF requires aligned accessors
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buffer.size();
    view.byteLength = bytes;
    view.target = target;
    buffer.resize(buffer.size() + bytes);
    std::memcpy(buffer.data() + view.byteOffset, data, bytes);
    model_->bufferViews.push_back(view);

    tinygltf::Accessor accessor;
    accessor.bufferView = static_cast<int>(model_->bufferViews.size()) - 1;
    accessor.componentType = component_type;
    accessor.count = count;
    accessor.type = type;
    model_->accessors.push_back(accessor);
    return static_cast<int>(model_->accessors.size()) - 1;
  }

  // POSITION accessors must carry min and max (glTF 2.0 §5.1.1).
  static void SetBounds(const std::vector<Eigen::Vector3f>& values, tinygltf::Accessor* accessor) {
    Eigen::Vector3f low = Eigen::Vector3f::Constant(0.f), high = low;
    if (!values.empty()) low = high = values.front();
    for (const Eigen::Vector3f& v : values) {
      low = low.cwiseMin(v);
      high = high.cwiseMax(v);
    }
    accessor->minValues = {low.x(), low.y(), low.z()};
    accessor->maxValues = {high.x(), high.y(), high.z()};
  }

  tinygltf::Model* model_;
};

Eigen::Vector3f ToYUp(const Eigen::Vector3d& p) {
  return ZUpToYUp(p).cast<float>();
}

// Objects always blend (alpha = pi, docs/method.md §2), even at pi = 1, so every object
// material behaves the same in a viewer; lines are opaque.
int AddMaterial(tinygltf::Model* model, const std::string& name, const Rgb& rgb, double alpha,
                bool blend) {
  tinygltf::Material material;
  material.name = name;
  material.pbrMetallicRoughness.baseColorFactor = {SrgbToLinear(rgb[0]), SrgbToLinear(rgb[1]),
                                                   SrgbToLinear(rgb[2]), alpha};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 0.8;
  if (blend) material.alphaMode = "BLEND";
  // Transparent objects are seen from inside too (opacity = pi, docs/method.md §2).
  material.doubleSided = true;
  model->materials.push_back(material);
  return static_cast<int>(model->materials.size()) - 1;
}

int AddNode(tinygltf::Model* model, tinygltf::Node node) {
  model->nodes.push_back(std::move(node));
  const int index = static_cast<int>(model->nodes.size()) - 1;
  model->scenes[0].nodes.push_back(index);
  return index;
}

tinygltf::Value Number(double value) {
  return std::isfinite(value) ? tinygltf::Value(value) : tinygltf::Value();  // null
}

// What Blender shows as the object's custom properties.
tinygltf::Value ObjectExtras(const OMapObject& object) {
  tinygltf::Value::Object extras;
  extras["id"] = tinygltf::Value(object.id);
  extras["class"] = tinygltf::Value(object.class_name);
  extras["existence_probability"] = Number(object.existence_probability);
  extras["diameter_m"] = Number(object.diameter_m);
  extras["height_m"] = Number(object.height_m);
  extras["base_point_world_m"] = tinygltf::Value(tinygltf::Value::Array{
      Number(object.base_world.x()), Number(object.base_world.y()), Number(object.base_world.z())});
  extras["num_detections"] = tinygltf::Value(object.num_detections);
  tinygltf::Value::Object histogram;
  for (const auto& [name, probability] : object.class_histogram)
    histogram[name] = Number(probability);
  extras["class_histogram"] = tinygltf::Value(histogram);
  tinygltf::Value::Array rows;
  for (int r = 0; r < 5; ++r) {
    tinygltf::Value::Array row;
    for (int c = 0; c < 5; ++c) row.push_back(Number(object.covariance(r, c)));
    rows.emplace_back(row);
  }
  extras["covariance"] = tinygltf::Value(rows);
  // The covariance stays in the map's own Z-up world frame, not glTF's.
  extras["covariance_order"] =
      tinygltf::Value(std::string("x, y, z, diameter, height (world Z up; m^2)"));
  return tinygltf::Value(extras);
}

void AddObject(tinygltf::Model* model, BufferBuilder* buffers, const OMapObject& object,
               const Rgb& rgb, int segments) {
  // Local mesh in Y-up around the node's origin, so Blender's object origin
  // sits at the base point.
  TriangleMesh mesh = CylinderMesh(object.diameter_m, object.height_m, segments);
  for (Eigen::Vector3f& p : mesh.positions) p = ToYUp(p.cast<double>());
  for (Eigen::Vector3f& n : mesh.normals) n = ToYUp(n.cast<double>());

  tinygltf::Primitive primitive;
  primitive.attributes["POSITION"] = buffers->AddVec3(mesh.positions, true);
  primitive.attributes["NORMAL"] = buffers->AddVec3(mesh.normals, false);
  primitive.indices = buffers->AddIndices(mesh.indices);
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.material =
      AddMaterial(model, ObjectLabel(object), rgb, object.existence_probability, true);
  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = ObjectLabel(object);
  gltf_mesh.primitives.push_back(primitive);
  model->meshes.push_back(gltf_mesh);

  tinygltf::Node node;
  node.name = ObjectLabel(object);
  node.mesh = static_cast<int>(model->meshes.size()) - 1;
  const Eigen::Vector3f base = ToYUp(object.base_world);
  node.translation = {base.x(), base.y(), base.z()};
  node.extras = ObjectExtras(object);
  AddNode(model, node);
}

// Line primitives (strip or separate segments) as one node with one mesh.
void AddLines(tinygltf::Model* model, BufferBuilder* buffers, const std::string& name,
              const std::vector<Eigen::Vector3f>& points, int mode, const Rgb& rgb) {
  tinygltf::Primitive primitive;
  primitive.attributes["POSITION"] = buffers->AddVec3(points, true);
  primitive.mode = mode;
  primitive.material = AddMaterial(model, name, rgb, 1.0, false);
  tinygltf::Mesh mesh;
  mesh.name = name;
  mesh.primitives.push_back(primitive);
  model->meshes.push_back(mesh);
  tinygltf::Node node;
  node.name = name;
  node.mesh = static_cast<int>(model->meshes.size()) - 1;
  AddNode(model, node);
}

// Trajectories float 1 cm above the floor so they do not flicker against the grid.
constexpr double kTrajectoryHeightM = 0.01;

std::vector<Eigen::Vector3f> FloorGrid(const Eigen::Vector4d& extent) {
  std::vector<Eigen::Vector3f> points;
  const double x0 = std::floor(extent[0]), y0 = std::floor(extent[1]);
  const double x1 = std::ceil(extent[2]), y1 = std::ceil(extent[3]);
  for (double x = x0; x <= x1 + 1e-9; x += 1.0) {
    points.push_back(ToYUp({x, y0, 0.0}));
    points.push_back(ToYUp({x, y1, 0.0}));
  }
  for (double y = y0; y <= y1 + 1e-9; y += 1.0) {
    points.push_back(ToYUp({x0, y, 0.0}));
    points.push_back(ToYUp({x1, y, 0.0}));
  }
  return points;
}

tinygltf::Model BuildModel(const ExportScene& scene, const ExportOptions& options) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "oslam export " OSLAM_VERSION;
  model.scenes.emplace_back();
  model.scenes[0].name = "O-Map";
  model.defaultScene = 0;
  BufferBuilder buffers(&model);

  for (const OMapObject* object : ShownObjects(scene.map, options.min_existence))
    AddObject(&model, &buffers, *object, ClassColour(scene.classes, object->class_name),
              options.cylinder_segments);
  for (const NamedTrajectory& trajectory : SceneTrajectories(scene)) {
    if (trajectory.poses.size() < 2) continue;  // a strip needs two points
    std::vector<Eigen::Vector3f> points;
    for (const Pose2& pose : trajectory.poses)
      points.push_back(ToYUp({pose.x, pose.y, kTrajectoryHeightM}));
    AddLines(&model, &buffers, "trajectory " + trajectory.name, points, TINYGLTF_MODE_LINE_STRIP,
             trajectory.rgb);
  }
  if (options.floor_grid)
    AddLines(&model, &buffers, "floor grid",
             FloorGrid(FloorExtent(scene, options.min_existence, 0.5)), TINYGLTF_MODE_LINE,
             {170, 170, 170});
  model.buffers[0].name = "oslam";
  // An empty buffer is invalid glTF (byteLength >= 1): drop it for an empty scene.
  if (model.buffers[0].data.empty()) model.buffers.clear();
  return model;
}

}  // namespace

double SrgbToLinear(int component) {
  const double c = component / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

void WriteGltf(const ExportScene& scene, const ExportOptions& options, const std::string& path) {
  std::string why;
  if (!options.Validate(&why)) throw Error::InFile(path, why);
  const tinygltf::Model model = BuildModel(scene, options);
  const bool binary = path.size() >= 4 && path.compare(path.size() - 4, 4, ".glb") == 0;
  WriteAtomically(path, [&](const std::string& temp) {
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToFile(&model, temp, /*embedImages=*/true, /*embedBuffers=*/true,
                                     /*prettyPrint=*/!binary, binary))
      throw Error::InFile(path, "cannot write glTF");
  });
}

}  // namespace oslam
