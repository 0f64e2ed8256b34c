#include "export/ply_writer.h"

#include <cmath>

#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "export/cylinder_mesh.h"

namespace oslam {
namespace {

pcl::PointXYZRGBA ColouredPoint(const Eigen::Vector3f& p, const Rgb& rgb, double alpha) {
  pcl::PointXYZRGBA point;
  point.x = p.x();
  point.y = p.y();
  point.z = p.z();
  point.r = static_cast<uint8_t>(rgb[0]);
  point.g = static_cast<uint8_t>(rgb[1]);
  point.b = static_cast<uint8_t>(rgb[2]);
  point.a = static_cast<uint8_t>(std::lround(255.0 * std::clamp(alpha, 0.0, 1.0)));
  return point;
}

void AppendObject(const OMapObject& object, const Rgb& rgb, int segments,
                  pcl::PointCloud<pcl::PointXYZRGBA>* cloud, std::vector<pcl::Vertices>* polygons) {
  const TriangleMesh mesh = CylinderMesh(object.diameter_m, object.height_m, segments);
  const auto first = static_cast<uint32_t>(cloud->size());
  const Eigen::Vector3f base = object.base_world.cast<float>();
  for (const Eigen::Vector3f& p : mesh.positions)
    cloud->push_back(ColouredPoint(p + base, rgb, object.existence_probability));
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    pcl::Vertices triangle;
    for (int k = 0; k < 3; ++k)
      triangle.vertices.push_back(static_cast<pcl::index_t>(first + mesh.indices[t + k]));
    polygons->push_back(triangle);
  }
}

}  // namespace

void WritePlyMesh(const ExportScene& scene, const ExportOptions& options, const std::string& path,
                  PlyEncoding encoding) {
  std::string why;
  if (!options.Validate(&why)) throw Error::InFile(path, why);
  pcl::PointCloud<pcl::PointXYZRGBA> cloud;
  pcl::PolygonMesh mesh;
  for (const OMapObject* object : ShownObjects(scene.map, options.min_existence))
    AppendObject(*object, ClassColour(scene.classes, object->class_name), options.cylinder_segments,
                 &cloud, &mesh.polygons);
  pcl::toPCLPointCloud2(cloud, mesh.cloud);
  WriteAtomically(path, [&](const std::string& memory_path) {
    // Millimetre-and-better precision in ASCII: PCL's default of 5 digits
    // would round coordinates beyond 10 m to centimetres.
    const int status = encoding == PlyEncoding::kBinary
                           ? pcl::io::savePLYFileBinary(memory_path, mesh)
                           : pcl::io::savePLYFile(memory_path, mesh, 8);
    if (status != 0) throw Error::InFile(path, "cannot write PLY mesh");
  });
}

void WritePlyTrajectories(const ExportScene& scene, const std::string& path, PlyEncoding encoding) {
  constexpr float kHeightM = 0.01f;
  pcl::PointCloud<pcl::PointXYZRGBA> cloud;
  for (const NamedTrajectory& trajectory : SceneTrajectories(scene))
    for (const Pose2& pose : trajectory.poses)
      cloud.push_back(ColouredPoint(
          Eigen::Vector3f(static_cast<float>(pose.x), static_cast<float>(pose.y), kHeightM),
          trajectory.rgb, 1.0));
  if (cloud.empty()) throw Error::InFile(path, "no trajectory to write");
  WriteAtomically(path, [&](const std::string& memory_path) {
    pcl::PLYWriter writer;
    // No "camera" element: it is PCL-specific and other readers warn about it.
    const int status = writer.write(memory_path, cloud, encoding == PlyEncoding::kBinary,
                                    /*use_camera=*/false);
    if (status != 0) throw Error::InFile(path, "cannot write PLY trajectory");
  });
}

}  // namespace oslam
