// The real Victoria Park data (../shared/data/victoria_park, GTSAM format
// with its landmark ids): the known-association solve converges to a sane
// map. Skipped when the shared data is absent. Label: slow.
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "mapping/landmark_slam.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

// The real data: GTSAM's victoria_park.txt with its landmark ids.
TEST(LandmarkSlamRealTest, VictoriaParkWithIdsConverges) {
  const std::string shared = testing::SharedDataDir();
  const std::string path = shared + "/victoria_park/with_ids/victoria_park.txt";
  if (shared.empty() || !std::ifstream(path))
    GTEST_SKIP() << "no " << path << " (../shared/data absent)";
  const LandmarkDataset data = ReadGtsamLandmarks(path);
  EXPECT_EQ(data.num_poses, 6969);
  EXPECT_EQ(data.sightings.size(), 3640u);
  LandmarkSlam slam;
  const LandmarkSlamResult result = slam.Solve(data, GivenAssociation(data));
  const SolverSummary& s = result.summary;
  ASSERT_EQ(s.termination, TerminationType::kConverged) << s.message;
  EXPECT_EQ(result.landmarks.size(), 151u);
  EXPECT_LT(s.final_cost, s.initial_cost);
  const double chi2 = 2.0 * s.final_cost / s.num_residuals;
  std::printf("chi2 per residual %.4f, length %.1f m, %d iterations, %.3f s\n", chi2,
              TrajectoryLength(result.trajectory), s.iterations, s.total_time_s);
  // GTSAM's landmark noise (bearing 0.2 rad, range 0.63 m) is generous for
  // a laser: the whitened residuals are small (measured 0.20 per residual).
  EXPECT_GT(chi2, 0.1);
  EXPECT_LT(chi2, 0.4);
  // The odometry integrates to 4,026.6 m; the solve bends it, not stretches it.
  const double length = TrajectoryLength(result.trajectory);
  EXPECT_GT(length, 3900.0);
  EXPECT_LT(length, 4150.0);
  EXPECT_TRUE(result.evidence.valid);
  // A minimum: re-solving from it changes nothing.
  const LandmarkSlamResult again = slam.Solve(data, GivenAssociation(data), &result);
  EXPECT_LE(again.summary.iterations, 2);
  EXPECT_NEAR(again.summary.final_cost, s.final_cost, 1e-6 * s.final_cost);
  for (const MappedLandmark& landmark : result.landmarks) {
    EXPECT_GT(landmark.covariance(0, 0), 0.0);
    EXPECT_LT(landmark.covariance(0, 0), 100.0);
  }
}

}  // namespace
}  // namespace oslam
