// Synthetic landmark worlds: what they hold (counts, clutter, view, spacing,
// the same world from the same seed), the default start reaching the
// optimum a start from the truth reaches where plain dead reckoning and
// fixed stages do not, and the formats written and read back.
#include "slam/landmark_simulation.h"

#include <cmath>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "core/angles.h"
#include "core/error.h"
#include "slam/landmark_formats.h"
#include "slam/landmark_slam.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

double Rmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i)
    sum += std::pow(a[i].x - b[i].x, 2) + std::pow(a[i].y - b[i].y, 2);
  return std::sqrt(sum / a.size());
}

TEST(LandmarkWorldTest, HoldsWhatWasAskedAndRepeatsFromItsSeed) {
  for (const LandmarkWorldLayout layout :
       {LandmarkWorldLayout::kCityGrid, LandmarkWorldLayout::kPark}) {
    LandmarkWorldOptions options;
    options.layout = layout;
    options.num_poses = 1500;
    options.num_landmarks = 120;
    options.clutter_per_scan = 0.2;
    const LandmarkWorld world = SimulateLandmarkWorld(options);
    const LandmarkDataset& data = world.data;
    ASSERT_EQ(data.num_poses, 1500);
    ASSERT_EQ(world.true_trajectory.size(), 1500u);
    ASSERT_EQ(world.true_landmarks.size(), 120u);
    ASSERT_EQ(data.odometry.size(), 1499u);
    ASSERT_EQ(world.true_association.size(), data.sightings.size());
    // Pose 0 is the frame; consecutive true poses a step apart.
    EXPECT_NEAR(world.true_trajectory[0].Vector().norm(), 0.0, 1e-12);
    EXPECT_NEAR(std::hypot(world.true_trajectory[7].x - world.true_trajectory[6].x,
                           world.true_trajectory[7].y - world.true_trajectory[6].y),
                1.0, 1e-9);
    int clutter = 0;
    std::set<int> seen, clutter_ids;
    for (size_t k = 0; k < data.sightings.size(); ++k) {
      const LandmarkSighting& s = data.sightings[k];
      EXPECT_LE(s.range_m, options.max_range_m + 5 * options.range_std_m);
      EXPECT_LE(std::abs(s.bearing_rad),
                options.field_of_view_rad / 2 + 5 * options.bearing_std_rad);
      if (world.true_association[k] < 0) {
        ++clutter;
        EXPECT_GE(s.landmark, options.num_landmarks);
        EXPECT_TRUE(clutter_ids.insert(s.landmark).second);  // a fresh id each
      } else {
        EXPECT_EQ(s.landmark, world.true_association[k]);
        seen.insert(s.landmark);
      }
    }
    // Poisson clutter of 0.2 per scan: 300 expected.
    EXPECT_GT(clutter, 240);
    EXPECT_LT(clutter, 360);
    EXPECT_GT(seen.size(), 30u);
    for (size_t a = 0; a < world.true_landmarks.size(); ++a)
      for (size_t b = a + 1; b < world.true_landmarks.size(); ++b)
        EXPECT_GE((world.true_landmarks[a] - world.true_landmarks[b]).norm(),
                  options.min_separation_m);
    const LandmarkWorld again = SimulateLandmarkWorld(options);
    ASSERT_EQ(again.data.sightings.size(), data.sightings.size());
    EXPECT_EQ(again.data.sightings.back().range_m, data.sightings.back().range_m);
    options.seed = 2;
    EXPECT_NE(SimulateLandmarkWorld(options).data.sightings.size(), data.sightings.size());
  }
  LandmarkWorldOptions crowded;
  crowded.num_landmarks = 5000;  // 2 m apart beside 4 x 4 blocks of 40 m: no room
  EXPECT_THROW(SimulateLandmarkWorld(crowded), Error);
  crowded.num_poses = 1;
  EXPECT_THROW(SimulateLandmarkWorld(crowded), Error);
}

// --lattice: every landmark on a distinct lattice point, between the least and
// most offset from the nearest street; more landmarks than such points, or a
// lattice in a park, are refused.
TEST(LandmarkWorldTest, LatticeLandmarksStandOnItsPointsBesideTheStreets) {
  LandmarkWorldOptions o;
  o.blocks = 4;
  o.block_m = 20;
  o.lattice_m = 5;
  o.num_landmarks = 100;
  o.num_poses = 200;
  const LandmarkWorld world = SimulateLandmarkWorld(o);
  ASSERT_EQ(world.true_landmarks.size(), 100u);
  std::set<std::pair<long, long>> points;
  for (const Eigen::Vector2d& p : world.true_landmarks) {
    const double i = p.x() / o.lattice_m, j = p.y() / o.lattice_m;
    EXPECT_NEAR(i, std::round(i), 1e-9);
    EXPECT_NEAR(j, std::round(j), 1e-9);
    points.insert({std::lround(i), std::lround(j)});
    const auto to_street = [&](double v) {  // the truth's frame starts at a crossing
      const double r = std::fmod(std::fmod(v, o.block_m) + o.block_m, o.block_m);
      return std::min(r, o.block_m - r);
    };
    const double d = std::min(to_street(p.x()), to_street(p.y()));
    EXPECT_GE(d, o.street_offset_min_m);
    EXPECT_LE(d, o.street_offset_max_m);
  }
  EXPECT_EQ(points.size(), 100u);  // distinct points
  // 5 m from a street in one direction, 5 or 10 m in the other: 128 points.
  o.num_landmarks = 129;
  EXPECT_THROW(SimulateLandmarkWorld(o), Error);
  o.num_landmarks = 10;
  o.layout = LandmarkWorldLayout::kPark;
  std::string why;
  EXPECT_FALSE(o.Validate(&why));
  EXPECT_NE(why.find("lattice"), std::string::npos);
}

// A city drive whose heading drifts 0.03 rad per step: plain dead reckoning
// (60 m off) and fixed stages of 50 or 10 poses all stop in false minima;
// the adaptive stages reach the cost a start from the true trajectory and
// landmarks reaches (method.md §16.1).
TEST(LandmarkWorldTest, DefaultStartReachesTheOptimumOfAStartFromTheTruth) {
  LandmarkWorldOptions options;
  options.num_poses = 2000;
  options.num_landmarks = 200;
  options.blocks = 5;
  options.odometry_std.z() = 0.03;
  options.seed = 3;
  const LandmarkWorld world = SimulateLandmarkWorld(options);
  LandmarkSlamOptions slam_options;
  slam_options.compute_landmark_covariances = false;
  const LandmarkSlamResult result =
      LandmarkSlam(slam_options).Solve(world.data, world.true_association);
  LandmarkSlamResult truth;
  truth.trajectory = world.true_trajectory;
  for (size_t id = 0; id < world.true_landmarks.size(); ++id) {
    MappedLandmark l;
    l.id = static_cast<int>(id);
    l.position_m = world.true_landmarks[id];
    truth.landmarks.push_back(l);
  }
  const LandmarkSlamResult from_truth =
      LandmarkSlam(slam_options).Solve(world.data, world.true_association, &truth);
  EXPECT_GT(result.initialisation_stages, 5);
  EXPECT_NEAR(result.summary.final_cost, from_truth.summary.final_cost,
              1e-6 * from_truth.summary.final_cost);
  EXPECT_LT(Rmse(result.trajectory, from_truth.trajectory), 1e-3);
  EXPECT_LT(Rmse(result.trajectory, world.true_trajectory),
            0.2 * Rmse(world.data.dead_reckoning, world.true_trajectory));
  for (const auto& [gate, window] : {std::pair<double, int>{0, 0}, {0, 50}, {0, 10}}) {
    LandmarkSlamOptions other = slam_options;
    other.initialisation_gate = gate;
    other.initialisation_window_poses = window;
    EXPECT_GT(LandmarkSlam(other).Solve(world.data, world.true_association).summary.final_cost,
              1.2 * from_truth.summary.final_cost)
        << "window " << window;
  }
}

TEST(LandmarkWorldTest, WrittenInEveryFormatAndReadBack) {
  LandmarkWorldOptions options;
  options.num_poses = 300;
  options.num_landmarks = 40;
  options.blocks = 2;
  const LandmarkWorld world = SimulateLandmarkWorld(options);
  testing::TempDir dir;
  LandmarkSlamOptions slam_options;
  slam_options.compute_landmark_covariances = false;
  const double cost =
      LandmarkSlam(slam_options).Solve(world.data, GivenAssociation(world.data)).summary.final_cost;
  double point_cost = -1;
  for (const LandmarkFormat format : {LandmarkFormat::kGtsam, LandmarkFormat::kG2o,
                                      LandmarkFormat::kIsam, LandmarkFormat::kToro}) {
    const std::string path = dir.Path(std::string("world.") + LandmarkFormatName(format));
    WriteLandmarkDataset(world.data, format, path);
    EXPECT_EQ(DetectLandmarkFormat(path).format, format) << path;
    const LandmarkDataset read = ReadLandmarkDataset(path, format);
    ASSERT_EQ(read.num_poses, world.data.num_poses) << path;
    ASSERT_EQ(read.odometry.size(), world.data.odometry.size());
    EXPECT_TRUE(read.odometry[5].covariance.isApprox(world.data.odometry[5].covariance, 1e-9));
    EXPECT_LT(Rmse(read.dead_reckoning, world.data.dead_reckoning), 1e-9);
    if (format == LandmarkFormat::kToro) {
      EXPECT_TRUE(read.sightings.empty());
      continue;
    }
    ASSERT_EQ(read.sightings.size(), world.data.sightings.size()) << path;
    // The k-th sighting written is the k-th read (the truth's association
    // file lines up with it), same pose and landmark.
    for (size_t k = 0; k < read.sightings.size(); k += 17) {
      EXPECT_EQ(read.sightings[k].pose, world.data.sightings[k].pose);
      EXPECT_NEAR(read.sightings[k].range_m, world.data.sightings[k].range_m, 1e-9);
    }
    const double read_cost =
        LandmarkSlam(slam_options).Solve(read, GivenAssociation(read)).summary.final_cost;
    if (format == LandmarkFormat::kGtsam) {
      EXPECT_NEAR(read_cost, cost, 1e-6 * cost);  // BR lines: the same model
    } else {
      // g2o and iSAM hold the points with the first-order covariance: the
      // same problem as each other, close to the range-bearing one.
      if (point_cost < 0) point_cost = read_cost;
      EXPECT_NEAR(read_cost, point_cost, 1e-6 * point_cost);
      EXPECT_NEAR(read_cost, cost, 0.05 * cost);
    }
  }
  LandmarkDataset mounted = world.data;
  mounted.sensor_offset_m = Eigen::Vector2d(1, 0);
  EXPECT_THROW(WriteG2oLandmarks(mounted, dir.Path("m.g2o")), Error);
  WriteLandmarkWorldTruth(world, dir.Path("t.csv"), dir.Path("l.csv"), dir.Path("a.txt"));
  EXPECT_EQ(ReadAssociation(dir.Path("a.txt"), world.data.sightings.size()),
            world.true_association);
}

}  // namespace
}  // namespace oslam
