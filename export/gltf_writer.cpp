#include "export/gltf_writer.h"

#include <cmath>
#include <cstring>
#include <sstream>

#include <tiny_gltf.h>

#include "core/atomic_file.h"
#include "core/error.h"

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

Eigen::Vector3f ToYUp(const Eigen::Vector3f& p) {
  return ZUpToYUp(p.cast<double>()).cast<float>();
}

// Objects always blend (alpha = pi, docs/method.md §2), even at pi = 1, so
// every object material behaves the same in a viewer. Closed meshes are
// single-sided: with back faces culled a transparent object shows only its
// near side, whatever order a viewer draws its triangles in.
int AddMaterial(tinygltf::Model* model, const std::string& name, const Rgb& rgb, double alpha,
                bool blend, bool double_sided, double roughness = 0.8) {
  tinygltf::Material material;
  material.name = name;
  material.pbrMetallicRoughness.baseColorFactor = {SrgbToLinear(rgb[0]), SrgbToLinear(rgb[1]),
                                                   SrgbToLinear(rgb[2]), alpha};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = roughness;
  if (blend) material.alphaMode = "BLEND";
  material.doubleSided = double_sided;
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
tinygltf::Value ObjectExtras(const DisplayObject& shown) {
  const OMapObject& object = *shown.object;
  tinygltf::Value::Object extras;
  extras["id"] = tinygltf::Value(object.id);
  extras["class"] = tinygltf::Value(object.class_name);
  extras["shape"] = tinygltf::Value(std::string(ObjectShapeName(shown.shape)));
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

// A node with one triangle mesh (positions, normals, indices) of `material`,
// its vertices relative to `origin` (both Z up), placed at `origin`.
int AddMeshNode(tinygltf::Model* model, BufferBuilder* buffers, const std::string& name,
                const ShadedMesh& mesh, int material, const Eigen::Vector3f& origin) {
  std::vector<Eigen::Vector3f> positions, normals;
  positions.reserve(mesh.positions.size());
  normals.reserve(mesh.normals.size());
  for (const Eigen::Vector3f& p : mesh.positions) positions.push_back(ToYUp(p));
  for (const Eigen::Vector3f& n : mesh.normals) normals.push_back(ToYUp(n));
  tinygltf::Primitive primitive;
  primitive.attributes["POSITION"] = buffers->AddVec3(positions, true);
  primitive.attributes["NORMAL"] = buffers->AddVec3(normals, false);
  primitive.indices = buffers->AddIndices(mesh.indices);
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.material = material;
  tinygltf::Mesh gltf_mesh;
  gltf_mesh.name = name;
  gltf_mesh.primitives.push_back(primitive);
  model->meshes.push_back(gltf_mesh);

  tinygltf::Node node;
  node.name = name;
  node.mesh = static_cast<int>(model->meshes.size()) - 1;
  if (!origin.isZero()) {
    const Eigen::Vector3f translation = ToYUp(origin);
    node.translation = {translation.x(), translation.y(), translation.z()};
  }
  return AddNode(model, node);
}

// A flat rectangle [x0, x1] x [y0, y1] at height z facing up, as a mesh.
void AddRectangle(ShadedMesh* mesh, double x0, double y0, double x1, double y1, double z) {
  const auto first = static_cast<uint32_t>(mesh->positions.size());
  for (const auto& [x, y] : {std::pair{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}) {
    mesh->positions.emplace_back(static_cast<float>(x), static_cast<float>(y),
                                 static_cast<float>(z));
    mesh->normals.push_back(Eigen::Vector3f::UnitZ());
  }
  mesh->indices.insert(mesh->indices.end(),
                       {first, first + 1, first + 2, first, first + 2, first + 3});
}

// The floor plane at z = 0 and grid strips 2 mm above it: faces, not glTF
// lines, which Blender imports as loose edges that never render.
void AddFloor(tinygltf::Model* model, BufferBuilder* buffers, const DisplayScene& display,
              bool grid) {
  const Eigen::Vector4d& f = display.floor;
  ShadedMesh plane;
  AddRectangle(&plane, f[0], f[1], f[2], f[3], 0.0);
  AddMeshNode(model, buffers, "floor", plane,
              AddMaterial(model, "floor", {235, 235, 230}, 1.0, false, true, 1.0),
              Eigen::Vector3f::Zero());
  if (!grid) return;
  const double step = display.grid_step_m, half_width = 0.4 * display.tube_radius_m;
  constexpr double kGridHeightM = 0.002;
  ShadedMesh strips;
  for (double x = std::ceil(f[0] / step) * step; x <= f[2] + 1e-9; x += step)
    AddRectangle(&strips, x - half_width, f[1], x + half_width, f[3], kGridHeightM);
  for (double y = std::ceil(f[1] / step) * step; y <= f[3] + 1e-9; y += step)
    AddRectangle(&strips, f[0], y - half_width, f[2], y + half_width, kGridHeightM);
  AddMeshNode(model, buffers, "floor grid", strips,
              AddMaterial(model, "floor grid", {160, 160, 160}, 1.0, false, true, 1.0),
              Eigen::Vector3f::Zero());
}

tinygltf::Model BuildModel(const DisplayScene& display, const ExportOptions& options) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "oslam export " OSLAM_VERSION;
  model.scenes.emplace_back();
  model.scenes[0].name = "O-Map";
  model.defaultScene = 0;
  BufferBuilder buffers(&model);

  for (const DisplayObject& shown : display.objects) {
    // Local mesh around the node's origin, so Blender's object origin sits at
    // the base point.
    const Eigen::Vector3f base = shown.object->base_world.cast<float>();
    const int node =
        AddMeshNode(&model, &buffers, shown.label, Shade(shown.local),
                    AddMaterial(&model, shown.label, shown.rgb, shown.alpha, true, false), base);
    model.nodes[node].extras = ObjectExtras(shown);
  }
  for (const DisplayTrajectory& trajectory : display.trajectories) {
    if (trajectory.tube.triangles.empty()) continue;
    const std::string name = "trajectory " + trajectory.name;
    AddMeshNode(&model, &buffers, name, Shade(trajectory.tube),
                AddMaterial(&model, name, trajectory.rgb, 1.0, false, false, 0.5),
                Eigen::Vector3f::Zero());
  }
  if (!display.cameras.triangles.empty())
    AddMeshNode(&model, &buffers, "cameras", Shade(display.cameras),
                AddMaterial(&model, "cameras", {90, 90, 100}, 1.0, false, false),
                Eigen::Vector3f::Zero());
  AddFloor(&model, &buffers, display, options.floor_grid);
  model.buffers[0].name = "oslam";
  return model;
}

}  // namespace

double SrgbToLinear(int component) {
  const double c = component / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

std::string GltfBytes(const DisplayScene& display, const ExportOptions& options, bool binary) {
  const tinygltf::Model model = BuildModel(display, options);
  std::ostringstream bytes;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, bytes, /*prettyPrint=*/!binary, binary))
    throw Error("cannot encode the glTF");
  return bytes.str();
}

void WriteGltf(const ExportScene& scene, const ExportOptions& options, const std::string& path) {
  std::string why;
  if (!options.Validate(&why)) throw Error::InFile(path, why);
  const bool binary = path.size() >= 4 && path.compare(path.size() - 4, 4, ".glb") == 0;
  WriteFileAtomically(path, GltfBytes(BuildDisplayScene(scene, options), options, binary));
}

}  // namespace oslam
