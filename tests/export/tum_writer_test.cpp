// TUM trajectory files: re-read line by line as evo reads them (comment lines
// start with '#', then "time tx ty tz qx qy qz qw") and checked against the
// poses, the yaw recovered from the quaternion.
#include "export/tum_writer.h"

#include <cmath>
#include <sstream>

#include <gtest/gtest.h>

#include "export/export_fixture.h"

namespace oslam {
namespace {

TEST(TumWriter, ReadsBackAsTheSamePoses) {
  const std::vector<Pose2> poses = testing::FixtureScene().ground_truth;
  std::istringstream text(TumTrajectory(poses));
  std::string line;
  size_t row = 0;
  while (std::getline(text, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y, z, qx, qy, qz, qw;
    ASSERT_TRUE(fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw) << line;
    std::string extra;
    EXPECT_FALSE(fields >> extra) << "more than 8 fields: " << line;
    ASSERT_LT(row, poses.size());
    EXPECT_EQ(t, static_cast<double>(row));
    EXPECT_NEAR(x, poses[row].x, 1e-8);
    EXPECT_NEAR(y, poses[row].y, 1e-8);
    EXPECT_EQ(z, 0.0);
    EXPECT_EQ(qx, 0.0);
    EXPECT_EQ(qy, 0.0);
    EXPECT_NEAR(qx * qx + qy * qy + qz * qz + qw * qw, 1.0, 1e-9);
    const double yaw = 2.0 * std::atan2(qz, qw);
    EXPECT_NEAR(std::remainder(yaw - poses[row].theta, 2.0 * M_PI), 0.0, 1e-8);
    ++row;
  }
  EXPECT_EQ(row, poses.size());
}

}  // namespace
}  // namespace oslam
