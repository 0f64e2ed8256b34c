#include "export/ply_writer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "core/atomic_file.h"
#include "core/error.h"

namespace oslam {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "binary PLY is written as binary_little_endian from memory");

struct Vertex {
  Eigen::Vector3f position;
  std::array<uint8_t, 4> rgba;
};

std::array<uint8_t, 4> Rgba(const Rgb& rgb, double alpha) {
  return {static_cast<uint8_t>(rgb[0]), static_cast<uint8_t>(rgb[1]), static_cast<uint8_t>(rgb[2]),
          static_cast<uint8_t>(std::lround(255.0 * std::clamp(alpha, 0.0, 1.0)))};
}

class PlyBuilder {
 public:
  explicit PlyBuilder(PlyEncoding encoding) : encoding_(encoding) {}

  std::string Header(const std::string& comment, size_t vertices, const std::string& element,
                     size_t count, const std::vector<std::string>& properties) const {
    std::string header = "ply\nformat ";
    header += encoding_ == PlyEncoding::kBinary ? "binary_little_endian" : "ascii";
    header += " 1.0\ncomment " + comment + "\nelement vertex " + std::to_string(vertices) +
              "\nproperty float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\n"
              "property uchar alpha\n";
    if (count > 0 || element == "face") {
      header += "element " + element + " " + std::to_string(count) + "\n";
      for (const std::string& property : properties) header += "property " + property + "\n";
    }
    return header + "end_header\n";
  }

  void AddVertex(const Vertex& v, std::string* out) const {
    if (encoding_ == PlyEncoding::kBinary) {
      Append(v.position.data(), 3 * sizeof(float), out);
      Append(v.rgba.data(), 4, out);
      return;
    }
    char line[96];
    const int n =
        std::snprintf(line, sizeof(line), "%.9g %.9g %.9g %d %d %d %d\n", v.position.x(),
                      v.position.y(), v.position.z(), v.rgba[0], v.rgba[1], v.rgba[2], v.rgba[3]);
    out->append(line, static_cast<size_t>(n));
  }

  // A face ("list uchar int") or an edge (two ints).
  void AddIndices(const uint32_t* indices, int count, bool counted, std::string* out) const {
    if (encoding_ == PlyEncoding::kBinary) {
      if (counted) out->push_back(static_cast<char>(count));
      for (int k = 0; k < count; ++k) {
        const auto index = static_cast<int32_t>(indices[k]);
        Append(&index, sizeof(index), out);
      }
      return;
    }
    std::string line = counted ? std::to_string(count) : "";
    for (int k = 0; k < count; ++k) {
      if (!line.empty()) line += ' ';
      line += std::to_string(indices[k]);
    }
    *out += line + "\n";
  }

 private:
  static void Append(const void* data, size_t bytes, std::string* out) {
    out->append(static_cast<const char*>(data), bytes);
  }
  PlyEncoding encoding_;
};

std::string Comment(const std::string& what) {
  return "oslam " OSLAM_VERSION ": " + what + "; world frame, Z up, metres";
}

}  // namespace

std::string PlyMeshBytes(const DisplayScene& display, PlyEncoding encoding) {
  const PlyBuilder ply(encoding);
  std::vector<Vertex> vertices;
  std::vector<std::array<uint32_t, 3>> faces;
  for (const DisplayObject& shown : display.objects) {
    const auto first = static_cast<uint32_t>(vertices.size());
    const std::array<uint8_t, 4> rgba = Rgba(shown.rgb, shown.alpha);
    const ClosedMesh world = shown.World();
    for (const Eigen::Vector3f& p : world.positions) vertices.push_back({p, rgba});
    for (const std::array<uint32_t, 3>& t : world.triangles)
      faces.push_back({first + t[0], first + t[1], first + t[2]});
  }
  std::string bytes =
      ply.Header(Comment("O-Map objects, one closed mesh each, alpha = pi"), vertices.size(),
                 "face", faces.size(), {"list uchar int vertex_indices"});
  bytes.reserve(bytes.size() + vertices.size() * 16 + faces.size() * 13);
  for (const Vertex& v : vertices) ply.AddVertex(v, &bytes);
  for (const std::array<uint32_t, 3>& f : faces) ply.AddIndices(f.data(), 3, true, &bytes);
  return bytes;
}

std::string PlyTrajectoryBytes(const DisplayScene& display, const ExportScene& scene,
                               PlyEncoding encoding) {
  const PlyBuilder ply(encoding);
  std::vector<Vertex> vertices;
  std::vector<std::array<uint32_t, 2>> edges;
  const std::vector<NamedTrajectory> trajectories = SceneTrajectories(scene);
  for (size_t t = 0; t < trajectories.size(); ++t) {
    const double z = t < display.trajectories.size() ? display.trajectories[t].z_m : 0.01;
    const std::array<uint8_t, 4> rgba = Rgba(trajectories[t].rgb, 1.0);
    const auto first = static_cast<uint32_t>(vertices.size());
    for (size_t i = 0; i < trajectories[t].poses.size(); ++i) {
      const Pose2& pose = trajectories[t].poses[i];
      vertices.push_back({Eigen::Vector3f(static_cast<float>(pose.x), static_cast<float>(pose.y),
                                          static_cast<float>(z)),
                          rgba});
      if (i > 0)
        edges.push_back({first + static_cast<uint32_t>(i) - 1, first + static_cast<uint32_t>(i)});
    }
  }
  if (vertices.empty()) return "";
  std::string bytes =
      ply.Header(Comment("trajectories estimated (black), odometry (red), ground truth (green)"),
                 vertices.size(), "edge", edges.size(), {"int vertex1", "int vertex2"});
  for (const Vertex& v : vertices) ply.AddVertex(v, &bytes);
  for (const std::array<uint32_t, 2>& e : edges) ply.AddIndices(e.data(), 2, false, &bytes);
  return bytes;
}

void WritePlyMesh(const ExportScene& scene, const ExportOptions& options, const std::string& path,
                  PlyEncoding encoding) {
  std::string why;
  if (!options.Validate(&why)) throw Error::InFile(path, why);
  WriteFileAtomically(path, PlyMeshBytes(BuildDisplayScene(scene, options), encoding));
}

void WritePlyTrajectories(const ExportScene& scene, const std::string& path, PlyEncoding encoding) {
  const std::string bytes =
      PlyTrajectoryBytes(BuildDisplayScene(scene, ExportOptions{}), scene, encoding);
  if (bytes.empty()) throw Error::InFile(path, "no trajectory to write");
  WriteFileAtomically(path, bytes);
}

}  // namespace oslam
