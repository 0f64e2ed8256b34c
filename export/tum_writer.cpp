#include "export/tum_writer.h"

#include <cmath>
#include <cstdio>

namespace oslam {

std::string TumTrajectory(const std::vector<Pose2>& poses) {
  std::string text = "# oslam " OSLAM_VERSION ": timestamp (frame number) tx ty tz qx qy qz qw\n";
  char line[160];
  for (size_t i = 0; i < poses.size(); ++i) {
    const Pose2& pose = poses[i];
    const int n = std::snprintf(line, sizeof(line), "%zu %.9g %.9g 0 0 0 %.9g %.9g\n", i, pose.x,
                                pose.y, std::sin(0.5 * pose.theta), std::cos(0.5 * pose.theta));
    text.append(line, static_cast<size_t>(n));
  }
  return text;
}

}  // namespace oslam
