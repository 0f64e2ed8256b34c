// glTF 2.0 export of an O-Map (tinygltf): one capped cylinder mesh per object
// in its class colour with alpha = existence probability, the trajectories as
// line strips, an optional floor grid. The world is Z up and glTF is Y up, so
// every coordinate goes through ZUpToYUp: Blender's importer turns it back and
// the map stands upright.
#pragma once

#include <string>

#include "export/export_scene.h"

namespace oslam {

// Writes `path` atomically: binary glTF for ".glb", else JSON glTF with the
// buffer embedded as a data URI (one self-contained file). Throws
// oslam::Error naming the file when it cannot be written.
void WriteGltf(const ExportScene& scene, const ExportOptions& options, const std::string& path);

// sRGB display colour component (0..255) to the linear value glTF's
// baseColorFactor expects.
double SrgbToLinear(int component);

}  // namespace oslam
