// PLY export for MeshLab and CloudCompare, written by oslam itself (PLY is a
// simple format; a library would add header lines of its own and cannot
// write edges). Coordinates stay in the map's own Z-up world frame (PLY has
// no convention, MeshLab none either).
#pragma once

#include <string>

#include "export/display_scene.h"
#include "export/export_scene.h"

namespace oslam {

enum class PlyEncoding { kAscii, kBinary };

// The shown objects, each one closed mesh with shared vertices in the shape
// of its class (MeshLab: one component per object, no holes, watertight),
// with per-vertex RGBA: the class display colour and alpha = round(255 pi).
std::string PlyMeshBytes(const DisplayScene& display, PlyEncoding encoding);

// The trajectories as vertices joined by edges (a polyline each), in frame
// order, in their display colours (estimated black, odometry red, ground
// truth green), at the heights of the glTF's tubes. Empty when there is no
// trajectory.
std::string PlyTrajectoryBytes(const DisplayScene& display, const ExportScene& scene,
                               PlyEncoding encoding);

// Write the above atomically; throw oslam::Error naming the file on failure
// (WritePlyTrajectories also when the scene has no trajectory).
void WritePlyMesh(const ExportScene& scene, const ExportOptions& options, const std::string& path,
                  PlyEncoding encoding);
void WritePlyTrajectories(const ExportScene& scene, const std::string& path, PlyEncoding encoding);

}  // namespace oslam
