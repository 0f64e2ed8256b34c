// glTF 2.0 export of an O-Map (tinygltf) as a scene to look at in Blender or
// any glTF viewer (docs/export.md has the legend):
//  - one node per object in the shape of its class, its class colour with
//    alpha = existence probability; closed and single-sided, so a
//    transparent object never shows its own far side or inner caps;
//  - the trajectories as thin tubes, one node and one named material each
//    ("trajectory estimated", "trajectory odometry", "trajectory ground truth");
//  - a floor plane with a grid of strips on it (both render, unlike lines);
//  - optionally the estimated camera poses as small pyramids.
// The world is Z up and glTF is Y up, so every coordinate goes through
// ZUpToYUp: Blender's importer turns it back and the map stands upright.
#pragma once

#include <string>

#include "export/display_scene.h"
#include "export/export_scene.h"

namespace oslam {

// The file's bytes: binary glTF (.glb) when `binary`, else JSON glTF with the
// buffer embedded as a data URI (one self-contained file).
std::string GltfBytes(const DisplayScene& display, const ExportOptions& options, bool binary);

// Writes `path` atomically: binary for ".glb", JSON otherwise. Throws
// oslam::Error naming the file when it cannot be written.
void WriteGltf(const ExportScene& scene, const ExportOptions& options, const std::string& path);

// sRGB display colour component (0..255) to the linear value glTF's
// baseColorFactor expects.
double SrgbToLinear(int component);

}  // namespace oslam
