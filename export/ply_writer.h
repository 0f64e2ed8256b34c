// PLY export (PCL) for MeshLab and CloudCompare. Coordinates stay in the
// map's own Z-up world frame (PLY has no convention, MeshLab none either).
#pragma once

#include <string>

#include "export/export_scene.h"

namespace oslam {

enum class PlyEncoding { kAscii, kBinary };

// All shown objects as one triangle mesh (each a capped cylinder) with
// per-vertex RGBA: the class display colour and alpha = round(255 pi).
// Written atomically; throws oslam::Error naming the file on failure.
void WritePlyMesh(const ExportScene& scene, const ExportOptions& options, const std::string& path,
                  PlyEncoding encoding);

// The trajectories as one coloured point set, each in frame order and in its
// display colour (estimated black, odometry red, ground truth green), 1 cm
// above the floor. PCL's PLY writer has no edge element, so the points carry
// the path; MeshLab shows them as a dotted line.
void WritePlyTrajectories(const ExportScene& scene, const std::string& path, PlyEncoding encoding);

}  // namespace oslam
