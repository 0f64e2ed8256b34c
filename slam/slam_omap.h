// A SLAM solve as an O-Map (docs/omap-format.md): the objects or landmarks,
// the trajectory, where the input came from, and the reports "solver" (with
// "keyframe_start" when the solve used it) and "evidence".
#pragma once

#include <string>
#include <vector>

#include "omap/omap.h"
#include "slam/geometric_slam.h"
#include "slam/landmark_slam.h"

namespace oslam {

// One object per mapped object, named class_names[class_index] (empty when
// out of range), existence probability 1 (the association is given).
OMap ToOMap(const GeometricSlamResult& result, const std::vector<std::string>& class_names,
            const OMapSource& source);

// One object per landmark, class `class_name`: base point (x, y, 0),
// diameter when measured else 0, height 0 (not observed); the covariance's
// rows and columns (x, y, diameter) filled.
OMap ToOMap(const LandmarkSlamResult& result, const std::string& class_name,
            const OMapSource& source);

}  // namespace oslam
