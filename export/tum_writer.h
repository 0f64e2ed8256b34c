// Trajectories in the TUM RGB-D format that evo and most SLAM benchmarks read
// ("timestamp tx ty tz qx qy qz qw" per line), e.g.
//   evo_ape tum trajectory_truth.txt trajectory_estimated.txt
// Run folders carry no timestamps, so the time is the frame number (seconds =
// frames); all three files share it, which is what evo associates poses by.
#pragma once

#include <string>
#include <vector>

#include "core/pose2.h"

namespace oslam {

// One line per pose, frame i at time i; z = 0, the rotation the yaw about +Z.
std::string TumTrajectory(const std::vector<Pose2>& poses);

}  // namespace oslam
