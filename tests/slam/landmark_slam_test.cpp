// Landmark SLAM with a given association: a simulated range-bearing world
// with known truth is recovered within stated tolerances; the evidence
// prefers the true association; warm starts and prefixes work.
#include "slam/landmark_slam.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "core/angles.h"
#include "core/error.h"
#include "slam/landmark_factors.h"
#include "slam/slam_omap.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

struct World {
  LandmarkDataset data;
  std::vector<Pose2> true_poses;
  std::map<int, Eigen::Vector2d> true_landmarks;
  std::map<int, double> true_diameters;
};

// A car driving twice around a 40 m x 30 m block of 36 trees (3 m steps,
// mount 3.78 m ahead, 0.5 m left), seeing trees within 25 m, ~160 poses.
// Trees with an even id have a measured diameter.
World SimulateWorld(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  World world;
  LandmarkDataset& data = world.data;
  data.format = "simulated";
  data.sensor_offset_m = Eigen::Vector2d(3.78, 0.5);
  data.has_landmark_ids = true;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      const int id = 10 + 6 * r + c;
      world.true_landmarks[id] = Eigen::Vector2d(-5.0 + 10.0 * c, -8.0 + 9.0 * r) +
                                 Eigen::Vector2d(2.0 * normal(rng), 2.0 * normal(rng));
      if (id % 2 == 0) world.true_diameters[id] = 0.2 + 0.05 * (id % 7);
    }
  // Path: rounded rectangle around the block, traversed twice.
  Pose2 pose{-15.0, -15.0, 0.0};
  const double step = 3.0;
  const int sides[4] = {22, 16, 22, 16};  // steps per side (66 m, 48 m)
  world.true_poses.push_back(pose);
  for (int lap = 0; lap < 2; ++lap)
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k < sides[side]; ++k) {
        const double turn = (k >= sides[side] - 4) ? (kPi / 2) / 4 : 0.0;  // turn over 4 steps
        pose = ComposePose(pose, {step, 0.0, turn});
        world.true_poses.push_back(pose);
      }
  // Re-express in the frame of the first pose (pose 0 is the gauge).
  const Pose2 origin = world.true_poses.front();
  auto to_origin = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector3d r = origin.WorldToRobot(Eigen::Vector3d(p.x(), p.y(), 0));
    return Eigen::Vector2d(r.x(), r.y());
  };
  for (Pose2& p : world.true_poses) {
    const Eigen::Vector2d xy = to_origin({p.x, p.y});
    p = {xy.x(), xy.y(), WrapAngle(p.theta - origin.theta)};
  }
  for (auto& [id, l] : world.true_landmarks) l = to_origin(l);

  data.num_poses = static_cast<int>(world.true_poses.size());
  const Eigen::Vector3d odometry_std(0.05, 0.03, 0.01);
  for (int i = 1; i < data.num_poses; ++i) {
    const Pose2& a = world.true_poses[i - 1];
    const Pose2& b = world.true_poses[i];
    const Eigen::Vector3d truth = a.WorldToRobot(Eigen::Vector3d(b.x, b.y, 0));
    RelativePoseMeasurement edge;
    edge.from = i - 1;
    edge.to = i;
    edge.delta = {truth.x() + odometry_std.x() * normal(rng),
                  truth.y() + odometry_std.y() * normal(rng),
                  WrapAngle(b.theta - a.theta) + odometry_std.z() * normal(rng)};
    edge.covariance = odometry_std.cwiseAbs2().asDiagonal();
    data.odometry.push_back(edge);
  }
  data.dead_reckoning.push_back(world.true_poses.front());
  for (const auto& edge : data.odometry)
    data.dead_reckoning.push_back(ComposePose(data.dead_reckoning.back(), edge.delta));

  const double range_std = 0.1, bearing_std = 0.01, diameter_std = 0.03;
  for (int i = 0; i < data.num_poses; ++i) {
    const Pose2& p = world.true_poses[i];
    const Eigen::Vector3d sensor = p.RobotToWorld(Eigen::Vector3d(3.78, 0.5, 0));
    for (const auto& [id, l] : world.true_landmarks) {
      const Eigen::Vector2d d = l - sensor.head<2>();
      if (d.norm() > 25.0) continue;
      LandmarkSighting s;
      s.pose = i;
      s.landmark = id;
      s.range_m = d.norm() + range_std * normal(rng);
      s.bearing_rad = WrapAngle(std::atan2(d.y(), d.x()) - p.theta + bearing_std * normal(rng));
      s.range_std_m = range_std;
      s.bearing_std_rad = bearing_std;
      if (world.true_diameters.count(id))
        s.diameter_m = world.true_diameters[id] + diameter_std * normal(rng);
      data.sightings.push_back(s);
    }
  }
  return world;
}

double PositionRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i)
    sum += std::pow(a[i].x - b[i].x, 2) + std::pow(a[i].y - b[i].y, 2);
  return std::sqrt(sum / a.size());
}

TEST(LandmarkSlamTest, RecoversASimulatedWorld) {
  const World world = SimulateWorld(5);
  ASSERT_GT(world.data.sightings.size(), 1000u);
  LandmarkSlamOptions options;
  options.diameter_std_m = 0.03;
  options.compute_pose_covariances = true;
  LandmarkSlam slam(options);
  const LandmarkSlamResult result = slam.Solve(world.data, GivenAssociation(world.data));
  ASSERT_EQ(result.summary.termination, TerminationType::kConverged) << result.summary.message;
  ASSERT_EQ(result.trajectory.size(), world.true_poses.size());
  ASSERT_EQ(result.landmarks.size(), world.true_landmarks.size());
  ASSERT_EQ(result.pose_covariances.size(), world.true_poses.size());
  EXPECT_EQ(result.num_sightings_used, static_cast<int>(world.data.sightings.size()));

  // Trajectory: dead reckoning drifts by metres; SLAM stays within 0.15 m RMS.
  const double odometry_rmse = PositionRmse(world.data.dead_reckoning, world.true_poses);
  const double slam_rmse = PositionRmse(result.trajectory, world.true_poses);
  // The errors are what the covariance predicts (RMS of sqrt(trace) of the
  // pose position covariances), and far below the dead reckoning's.
  double predicted = 0;
  for (const Eigen::Matrix3d& c : result.pose_covariances) predicted += c(0, 0) + c(1, 1);
  predicted = std::sqrt(predicted / result.pose_covariances.size());
  std::printf("trajectory RMSE: odometry %.3f m, SLAM %.3f m, predicted %.3f m\n", odometry_rmse,
              slam_rmse, predicted);
  EXPECT_GT(odometry_rmse, 1.0);
  EXPECT_LT(slam_rmse, 0.1 * odometry_rmse);
  EXPECT_LT(slam_rmse, 2.0 * predicted);
  EXPECT_GT(slam_rmse, 0.15 * predicted);
  double max_heading_error = 0;
  for (size_t i = 0; i < result.trajectory.size(); ++i)
    max_heading_error =
        std::max(max_heading_error,
                 std::abs(WrapAngle(result.trajectory[i].theta - world.true_poses[i].theta)));
  EXPECT_LT(max_heading_error, DegToRad(1.0));

  // Landmarks within 1 m; their covariances consistent: mean NEES of the
  // 2D positions about 2. The landmarks' errors are correlated through the
  // shared trajectory, so the mean over 36 of them spreads far more than
  // chi2(72)/36 would (0.5-2.7 over seeds 5, 11-13): accept 0.2-5.
  double nees = 0, max_error = 0;
  for (const MappedLandmark& landmark : result.landmarks) {
    const Eigen::Vector2d error = landmark.position_m - world.true_landmarks.at(landmark.id);
    max_error = std::max(max_error, error.norm());
    const Eigen::Matrix2d covariance = landmark.covariance.topLeftCorner<2, 2>();
    ASSERT_GT(covariance.determinant(), 0.0) << "landmark " << landmark.id;
    nees += error.dot(covariance.inverse() * error);
    if (world.true_diameters.count(landmark.id)) {
      EXPECT_NEAR(landmark.diameter_m, world.true_diameters.at(landmark.id), 0.03);
      EXPECT_NEAR(landmark.covariance(2, 2), 0.03 * 0.03 / landmark.num_sightings, 1e-6);
    } else {
      EXPECT_TRUE(std::isnan(landmark.diameter_m));
      EXPECT_EQ(landmark.covariance(2, 2), 0.0);
    }
  }
  nees /= result.landmarks.size();
  std::printf("landmarks: max error %.3f m, mean NEES %.2f\n", max_error, nees);
  for (const MappedLandmark& landmark : result.landmarks)
    EXPECT_EQ(result.FindLandmark(landmark.id), &landmark);
  EXPECT_EQ(result.FindLandmark(-1), nullptr);
  EXPECT_EQ(result.FindLandmark(result.landmarks.back().id + 1), nullptr);
  EXPECT_LT(max_error, 1.0);
  EXPECT_GT(nees, 0.2);
  EXPECT_LT(nees, 5.0);

  // Chi-square per degree of freedom near 1 (residuals match the noise).
  const double dof = result.summary.num_residuals - result.summary.num_parameters;
  const double chi2 = 2.0 * result.summary.final_cost / dof;
  EXPECT_GT(chi2, 0.8);
  EXPECT_LT(chi2, 1.2);
  EXPECT_TRUE(result.evidence.valid);
  EXPECT_EQ(result.pose_covariances[0], Eigen::Matrix3d::Zero());
  EXPECT_GT(result.pose_covariances.back()(0, 0), 0.0);
}

TEST(LandmarkSlamTest, EvidencePrefersTheTrueAssociation) {
  const World world = SimulateWorld(6);
  LandmarkSlam slam;
  const std::vector<int> truth = GivenAssociation(world.data);
  const LandmarkSlamResult right = slam.Solve(world.data, truth);
  ASSERT_TRUE(right.evidence.valid);
  // Merge two neighbouring trees, or split one tree's sightings in two: both
  // must lower log P(Z | J).
  std::vector<int> merged = truth, split = truth;
  int seen = 0;
  for (size_t k = 0; k < truth.size(); ++k) {
    if (truth[k] == 11) merged[k] = 10;
    if (truth[k] == 20 && (seen++ % 2 == 1)) split[k] = 99;
  }
  const LandmarkSlamResult wrong_merge = slam.Solve(world.data, merged);
  const LandmarkSlamResult wrong_split = slam.Solve(world.data, split);
  ASSERT_TRUE(wrong_merge.evidence.valid);
  ASSERT_TRUE(wrong_split.evidence.valid);
  EXPECT_LT(wrong_merge.evidence.log_evidence, right.evidence.log_evidence - 100.0);
  EXPECT_LT(wrong_split.evidence.log_evidence, right.evidence.log_evidence);
  EXPECT_EQ(wrong_merge.landmarks.size(), right.landmarks.size() - 1);

  // A singleton landmark with a flat prior: one sighting moved off tree 20
  // onto a landmark of its own. With the location prior (proper evidence)
  // that must cost evidence; the prior barely moves the map.
  LandmarkSlamOptions with_prior;
  with_prior.landmark_prior_std_m = 100.0;
  LandmarkSlam proper(with_prior);
  std::vector<int> singleton = truth;
  for (size_t k = 0; k < truth.size(); ++k)
    if (truth[k] == 20) {
      singleton[k] = 98;
      break;
    }
  const LandmarkSlamResult right_proper = proper.Solve(world.data, truth);
  const LandmarkSlamResult singleton_proper = proper.Solve(world.data, singleton);
  ASSERT_TRUE(singleton_proper.evidence.valid);
  EXPECT_LT(singleton_proper.evidence.log_evidence, right_proper.evidence.log_evidence);
  for (size_t j = 0; j < right.landmarks.size(); ++j)
    EXPECT_LT((right_proper.landmarks[j].position_m - right.landmarks[j].position_m).norm(), 1e-3);
  EXPECT_EQ(wrong_split.landmarks.size(), right.landmarks.size() + 1);
}

// A location prior of constant density moves nothing: the solution is the
// flat prior's, and each landmark adds log(density) to the evidence. A
// Gaussian prior pulls the landmarks toward its mean, the more the farther
// they are (here centred 300 m off, as a map's far side is from its centre).
TEST(LandmarkSlamTest, ALandmarkDensityAddsToTheEvidenceAndMovesNothing) {
  const World world = SimulateWorld(7);
  const std::vector<int> truth = GivenAssociation(world.data);
  const LandmarkSlamResult flat = LandmarkSlam().Solve(world.data, truth);
  LandmarkSlamOptions with_density;
  with_density.landmark_density_per_m2 = 1e-3;
  const LandmarkSlamResult dense = LandmarkSlam(with_density).Solve(world.data, truth);
  ASSERT_TRUE(flat.evidence.valid && dense.evidence.valid);
  EXPECT_NEAR(dense.evidence.log_evidence,
              flat.evidence.log_evidence + double(flat.landmarks.size()) * std::log(1e-3), 1e-6);
  EXPECT_LT(PositionRmse(dense.trajectory, flat.trajectory), 1e-9);
  for (size_t j = 0; j < flat.landmarks.size(); ++j)
    EXPECT_LT((dense.landmarks[j].position_m - flat.landmarks[j].position_m).norm(), 1e-9);

  LandmarkSlamOptions gaussian;
  gaussian.landmark_prior_std_m = 30.0;
  gaussian.landmark_prior_mean_m = Eigen::Vector2d(300, 0);
  const LandmarkSlamResult pulled = LandmarkSlam(gaussian).Solve(world.data, truth);
  EXPECT_GT(PositionRmse(pulled.trajectory, flat.trajectory), 0.1);

  std::string why;
  with_density.landmark_prior_std_m = 30.0;  // two location priors
  EXPECT_FALSE(with_density.Validate(&why));
  with_density.landmark_prior_std_m = 0;
  with_density.landmark_density_per_m2 = std::nan("");
  EXPECT_FALSE(with_density.Validate(&why));
}

TEST(LandmarkSlamTest, WarmStartLeftOutSightingsAndPrefix) {
  const World world = SimulateWorld(7);
  LandmarkSlam slam;
  const std::vector<int> truth = GivenAssociation(world.data);
  const LandmarkSlamResult cold = slam.Solve(world.data, truth);
  const LandmarkSlamResult warm = slam.Solve(world.data, truth, &cold);
  ASSERT_TRUE(warm.summary.IsUsable());
  EXPECT_LE(warm.summary.iterations, 2);
  EXPECT_NEAR(warm.evidence.log_evidence, cold.evidence.log_evidence, 1e-3);
  EXPECT_LT(PositionRmse(warm.trajectory, cold.trajectory), 1e-4);

  // -1 leaves a sighting out; a landmark with none disappears.
  std::vector<int> without = truth;
  int left_out = 0;
  for (size_t k = 0; k < truth.size(); ++k)
    if (truth[k] == 15) {
      without[k] = -1;
      ++left_out;
    }
  const LandmarkSlamResult fewer = slam.Solve(world.data, without, &cold);
  EXPECT_EQ(fewer.landmarks.size(), cold.landmarks.size() - 1);
  EXPECT_EQ(fewer.num_sightings_used, cold.num_sightings_used - left_out);

  std::vector<int> kept;
  const LandmarkDataset prefix = PosePrefix(world.data, 60, &kept);
  EXPECT_EQ(prefix.num_poses, 60);
  EXPECT_EQ(prefix.odometry.size(), 59u);
  for (const LandmarkSighting& s : prefix.sightings) EXPECT_LT(s.pose, 60);
  std::vector<int> prefix_association;
  for (int k : kept) prefix_association.push_back(truth[k]);
  const LandmarkSlamResult part = slam.Solve(prefix, prefix_association);
  EXPECT_EQ(part.summary.termination, TerminationType::kConverged);
  EXPECT_EQ(part.trajectory.size(), 60u);

  EXPECT_THROW(slam.Solve(world.data, std::vector<int>(3, 0)), Error);
  std::vector<int> bad = truth;
  bad[0] = -2;
  EXPECT_THROW(slam.Solve(world.data, bad), Error);

  // A zero-range first sighting does not place the landmark; only zero
  // ranges is an error.
  LandmarkDataset zero = world.data;
  zero.sightings[0].range_m = 0.0;
  const LandmarkSlamResult with_zero = slam.Solve(zero, truth);
  EXPECT_EQ(with_zero.summary.termination, TerminationType::kConverged);
  for (LandmarkSighting& s : zero.sightings)
    if (s.landmark == truth[0]) s.range_m = 0.0;
  EXPECT_THROW(slam.Solve(zero, truth), Error);
}

TEST(LandmarkSlamTest, OMapHasOneTreePerLandmark) {
  const World world = SimulateWorld(8);
  LandmarkSlam slam;
  const LandmarkSlamResult result = slam.Solve(world.data, GivenAssociation(world.data));
  const OMap map = ToOMap(result, "tree", {"park.txt", "known", std::nullopt, std::nan(""), 0});
  ASSERT_EQ(map.objects.size(), result.landmarks.size());
  for (size_t j = 0; j < map.objects.size(); ++j) {
    const OMapObject& object = map.objects[j];
    const MappedLandmark& landmark = result.landmarks[j];
    EXPECT_EQ(object.id, landmark.id);
    EXPECT_EQ(object.class_name, "tree");
    EXPECT_EQ(object.base_world.head<2>(), landmark.position_m);
    EXPECT_EQ(object.base_world.z(), 0.0);
    EXPECT_EQ(object.diameter_m, std::isfinite(landmark.diameter_m) ? landmark.diameter_m : 0.0);
    EXPECT_EQ(object.height_m, 0.0);
    EXPECT_EQ(object.existence_probability, 1.0);
    EXPECT_EQ(object.num_detections, landmark.num_sightings);
    EXPECT_EQ(object.covariance(1, 1), landmark.covariance(1, 1));
    EXPECT_EQ(object.covariance(3, 0), landmark.covariance(2, 0));
    EXPECT_EQ(object.covariance(2, 2), 0.0);
    EXPECT_FALSE(object.identity);
  }
  EXPECT_EQ(map.trajectory.size(), result.trajectory.size());
  EXPECT_EQ(map.source->run, "park.txt");
  ASSERT_EQ(map.reports.size(), 2u);
  EXPECT_EQ(map.reports[0].name, "solver");
  EXPECT_NE(map.reports[0].json.find("\"iterations\":" + std::to_string(result.summary.iterations)),
            std::string::npos);
  EXPECT_EQ(map.reports[0].json.find("keyframe_start"), std::string::npos);
  EXPECT_EQ(map.reports[1].name, "evidence");
  EXPECT_NEAR(TrajectoryLength(result.trajectory), 3.0 * (result.trajectory.size() - 1), 10.0);
}

}  // namespace
}  // namespace oslam
