// O-SLAM with the landmark ids hidden on the real Victoria Park data
// (../shared/data/victoria_park/with_ids): the recovered association agrees
// with the file's ids on pairs of sightings, and the trajectory is near the
// shipped-association solve. Skipped when the shared data is absent. Label:
// slow (about a minute on 2 cores).
#include <cstdio>
#include <fstream>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "association/association_metrics.h"
#include "pipeline/landmark_association.h"
#include "slam/landmark_data.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

TEST(LandmarkAssociationRealTest, VictoriaParkWithIdsHidden) {
  const std::string shared = testing::SharedDataDir();
  const std::string path = shared + "/victoria_park/with_ids/victoria_park.txt";
  if (shared.empty() || !std::ifstream(path))
    GTEST_SKIP() << "no " << path << " (../shared/data absent)";
  LandmarkDataset data = ReadGtsamLandmarks(path);
  // As `oslam map --unknown-association --odometry-noise-scale 10`: with the
  // file's odometry covariance the shipped association scores below all
  // tracks separate on the first 500 poses (docs/benchmarks.md).
  UnknownAssociationOptions options;
  for (RelativePoseMeasurement& edge : data.odometry) edge.covariance *= 10.0;
  const UnknownAssociationResult result = SolveUnknownAssociation(data, options);
  const std::vector<int> shipped = GivenAssociation(data);
  const PairwiseAgreement a = ComparePairwise(result.association, shipped);
  LandmarkSlamOptions known_options = options.target.slam;
  known_options.compute_landmark_covariances = false;
  const LandmarkSlamResult known = LandmarkSlam(known_options).Solve(data, shipped);
  const double rmse = TrajectoryRmse(result.solution.trajectory, known.trajectory);
  std::printf(
      "%zu landmarks (151 shipped), agreement %.5f, precision %.4f, recall %.4f, "
      "trajectory RMSE %.2f m, %.1f s\n",
      result.solution.landmarks.size(), a.agreement, a.precision, a.recall, rmse,
      result.total_time_s);
  // Measured (docs/benchmarks.md): 0.99923, 0.957, 0.9965, 3.3 m, 123 landmarks
  // (before the joint re-entry merges: 0.99308, 0.924, 0.616, 48.0 m, 207).
  EXPECT_GE(a.agreement, 0.998);
  EXPECT_GE(a.precision, 0.93);
  EXPECT_GE(a.recall, 0.97);
  EXPECT_LT(rmse, 8.0);
  EXPECT_GT(result.joint_merges, 0);
}

// The raw scans (detections_no_ids: clutter, Ackermann odometry from speed and
// steering), their first 2,000 poses with the raw-drive settings of
// docs/benchmarks.md: the trajectory against GPS, and no
// landmark seen twice in one scan.
TEST(LandmarkAssociationRealTest, VictoriaParkRawPrefixAgainstGps) {
  const std::string shared = testing::SharedDataDir();
  const std::string dir = shared + "/victoria_park/detections_no_ids/";
  if (shared.empty() || !std::ifstream(dir + "measurements.dat"))
    GTEST_SKIP() << "no " << dir << "measurements.dat (../shared/data absent)";
  const LandmarkDataset data =
      PosePrefix(ReadVictoriaRaw(dir + "measurements.dat", dir + "inputs.dat"), 2000);
  UnknownAssociationOptions options;
  options.min_track_sightings = 3;
  options.diameter_per_track = true;
  options.target.slam.diameter_std_m = 0.06;
  options.window_poses = 50;
  options.hill_climb_steps_per_track = 1;
  options.targeted_radius_m = 20;
  options.targeted_max_candidates = 10;
  options.sweep_radius_m = 1.5;
  options.joint_min_inliers = 0;
  const UnknownAssociationResult result = SolveUnknownAssociation(data, options);
  const std::vector<GpsFix> gps = ReadGps(dir + "gps.dat");
  const GpsError ours = CompareWithGps(result.solution.trajectory, data.pose_times, gps);
  const GpsError dead = CompareWithGps(data.dead_reckoning, data.pose_times, gps);
  std::set<std::pair<int, int>> seen;  // (landmark, pose)
  for (size_t k = 0; k < data.sightings.size(); ++k) {
    if (result.association[k] < 0) continue;  // clutter
    EXPECT_TRUE(seen.insert({result.association[k], data.sightings[k].pose}).second);
  }
  std::printf(
      "%zu landmarks, %ld clutter tracks; vs GPS %.2f m RMSE (dead reckoning %.2f m), %.1f s\n",
      result.solution.landmarks.size(), result.clutter_tracks, ours.rmse_m, dead.rmse_m,
      result.total_time_s);
  // Measured: 5.45 m (dead reckoning 32.1 m; GPS noise and the antenna offset included).
  EXPECT_LT(ours.rmse_m, 8.0);
  EXPECT_LT(ours.rmse_m, 0.5 * dead.rmse_m);
}

}  // namespace
}  // namespace oslam
