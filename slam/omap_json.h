// The O-Map as JSON (docs/omap-format.md): objects with their geometry,
// covariance and existence probability, the trajectory, and how the map was
// made (solver summary, evidence, source).
#pragma once

#include <string>
#include <vector>

#include "slam/geometric_slam.h"

namespace oslam {

struct OMapSource {
  std::string run_dir;
  std::string association;  // e.g. "known (ground truth)"
  double pixel_noise_px = 0;
  unsigned long seed = 0;
};

// class_names[i] names class index i. Non-finite numbers become null.
std::string OMapToJson(const GeometricSlamResult& result,
                       const std::vector<std::string>& class_names, const OMapSource& source);

// Written atomically.
void WriteOMap(const std::string& path, const GeometricSlamResult& result,
               const std::vector<std::string>& class_names, const OMapSource& source);

}  // namespace oslam
