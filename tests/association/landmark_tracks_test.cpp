// Tracks of planar landmark sightings: pure on a simulated drive, and the
// rules that keep them certain (an ambiguous gate, two sightings of one scan
// claiming one track, the pose gap) on hand-made scans.
#include "association/landmark_tracks.h"

#include <cmath>
#include <limits>
#include <set>

#include <gtest/gtest.h>

#include "core/error.h"
#include "tests/association/landmark_drives.h"

namespace oslam {
namespace {

// Poses 1 m apart along x, heading 0, the dead reckoning exact; sightings
// added at world points.
class Scans {
 public:
  explicit Scans(int num_poses) {
    data_.path = "scans";
    data_.num_poses = num_poses;
    for (int i = 0; i < num_poses; ++i) data_.dead_reckoning.push_back({double(i), 0.0, 0.0});
  }
  // Returns the sighting's index.
  int See(int pose, double x, double y) {
    LandmarkSighting s;
    s.pose = pose;
    const Eigen::Vector2d d(x - pose, y);
    s.range_m = d.norm();
    s.bearing_rad = std::atan2(d.y(), d.x());
    data_.sightings.push_back(s);
    return static_cast<int>(data_.sightings.size()) - 1;
  }
  std::vector<std::vector<int>> Tracks(double gate_m, int max_pose_gap) const {
    return BuildLandmarkTracks(data_, data_.dead_reckoning, {gate_m, max_pose_gap});
  }
  LandmarkDataset& data() { return data_; }

 private:
  LandmarkDataset data_;
};

using Tracks = std::vector<std::vector<int>>;

TEST(LandmarkTracksTest, TracksArePureAndSplitByLap) {
  const LandmarkDataset data = testing::SimulateDrive(3, nullptr);
  const auto tracks = BuildLandmarkTracks(data, data.dead_reckoning, {1.0, 2});
  std::set<int> trees;
  size_t sightings = 0;
  for (const auto& track : tracks) {
    for (int k : track) EXPECT_EQ(data.sightings[k].landmark, data.sightings[track[0]].landmark);
    trees.insert(data.sightings[track[0]].landmark);
    sightings += track.size();
  }
  EXPECT_EQ(sightings, data.sightings.size());
  EXPECT_EQ(trees.size(), 14u);
  EXPECT_GE(tracks.size(), 2 * trees.size());  // each lap at least one track per tree
  EXPECT_LT(tracks.size(), data.sightings.size() / 3);
  EXPECT_THROW(BuildLandmarkTracks(data, {}, {1.0, 2}), Error);
  EXPECT_THROW(BuildLandmarkTracks(data, data.dead_reckoning, {0.0, 2}), Error);
}

TEST(LandmarkTracksTest, FollowsALandmarkInPoseOrder) {
  Scans scans(4);
  // Listed out of pose order: the tracks are in pose order all the same.
  const int c = scans.See(2, 5.2, 1.0);
  const int a = scans.See(0, 5.0, 1.0);
  const int b = scans.See(1, 5.1, 1.0);
  const int d = scans.See(3, 5.3, 1.0);
  const int other = scans.See(1, 8.0, -2.0);  // a second landmark, first seen later
  EXPECT_EQ(scans.Tracks(1.0, 20), (Tracks{{a, b, c, d}, {other}}));
}

TEST(LandmarkTracksTest, ASightingInTwoGatesStartsAfresh) {
  Scans scans(3);
  const int a = scans.See(0, 5.0, 0.0);
  const int b = scans.See(0, 5.0, 1.2);        // 1.2 m from a: tracks of their own
  const int between = scans.See(1, 5.0, 0.6);  // within 1 m of both
  const int a2 = scans.See(2, 5.0, -0.5);      // only a's track is within 1 m
  EXPECT_EQ(scans.Tracks(1.0, 20), (Tracks{{a, a2}, {b}, {between}}));
}

TEST(LandmarkTracksTest, TwoSightingsOfOneScanClaimingATrackBothStartAfresh) {
  Scans scans(3);
  const int a = scans.See(0, 5.0, 0.0);
  const int up = scans.See(1, 5.0, 0.4);
  const int down = scans.See(1, 5.0, -0.4);
  // The first track is left as it was: a later sighting near its last one
  // is ambiguous with `up`'s and `down`'s, so it starts afresh too.
  const int later = scans.See(2, 5.0, 0.0);
  EXPECT_EQ(scans.Tracks(1.0, 20), (Tracks{{a}, {up}, {down}, {later}}));
  // Far enough apart, each continues its own track.
  Scans apart(2);
  const int p = apart.See(0, 5.0, 0.0), q = apart.See(0, 5.0, 3.0);
  const int p2 = apart.See(1, 5.0, 0.1), q2 = apart.See(1, 5.0, 3.1);
  EXPECT_EQ(apart.Tracks(1.0, 20), (Tracks{{p, p2}, {q, q2}}));
}

TEST(LandmarkTracksTest, APoseGapEndsATrack) {
  Scans scans(8);
  const int a = scans.See(0, 5.0, 1.0);
  const int b = scans.See(2, 5.0, 1.0);  // 2 poses on: still the track
  const int c = scans.See(5, 5.0, 1.0);  // 3 poses on: a new one
  EXPECT_EQ(scans.Tracks(1.0, 2), (Tracks{{a, b}, {c}}));
  EXPECT_EQ(scans.Tracks(1.0, 3), (Tracks{{a, b, c}}));
}

TEST(LandmarkTracksTest, SightingsWithoutRangeAreInNoTrack) {
  Scans scans(2);
  const int a = scans.See(0, 5.0, 1.0);
  scans.See(1, 1.0, 0.0);  // range 0: at the sensor, no bearing
  const int b = scans.See(1, 5.0, 1.0);
  EXPECT_EQ(scans.Tracks(1.0, 20), (Tracks{{a, b}}));
}

TEST(LandmarkTracksTest, OptionsNeedAPositiveFiniteGateAndAPoseGap) {
  std::string why;
  EXPECT_TRUE(LandmarkTrackOptions{}.Validate(&why));
  EXPECT_FALSE((LandmarkTrackOptions{0.0, 20}).Validate(&why));
  EXPECT_FALSE((LandmarkTrackOptions{std::numeric_limits<double>::infinity(), 20}).Validate(&why));
  EXPECT_FALSE((LandmarkTrackOptions{std::nan(""), 20}).Validate(&why));
  EXPECT_FALSE((LandmarkTrackOptions{1.0, 0}).Validate(&why));
  EXPECT_FALSE(why.empty());
  Scans scans(1);
  scans.See(0, 5.0, 0.0);
  EXPECT_THROW(scans.Tracks(1.0, 0), Error);
}

TEST(LandmarkTracksTest, SpacingIsTheMedianNearestNeighbourWithinAScan) {
  Scans scans(6);
  // Trees 3 m apart beside the road; every scan sees three of them.
  for (int pose = 0; pose < 5; ++pose)
    for (int tree = 0; tree < 3; ++tree) scans.See(pose, pose + 3.0 * tree, 4.0);
  scans.See(5, 7.0, -2.0);  // a scan with one sighting measures nothing
  EXPECT_NEAR(MedianCoVisibleSpacing(scans.data()), 3.0, 1e-9);
  Scans lonely(3);
  lonely.See(0, 1.0, 1.0);
  EXPECT_EQ(MedianCoVisibleSpacing(lonely.data()), 0.0);
}

// Trees on a 2 m grid (0.25 per m²), each scan seeing those ahead within
// 10 m: the estimate is the grid's density, within the percentiles' trim and
// the grid's granularity; a sensor missing every other sighting halves it
// (a lower bound).
TEST(LandmarkTracksTest, SightingDensityIsTheLandmarksPerSquareMetreInView) {
  Scans all(20), half(20);
  int seen = 0;
  for (int pose = 0; pose < 20; ++pose)
    for (int i = -20; i <= 40; ++i)
      for (int j = -10; j <= 10; ++j) {
        const double x = 2.0 * i + 1.0, y = 2.0 * j + 1.0;  // off the drive's line
        if (x < pose || std::hypot(x - pose, y) > 10.0) continue;
        all.See(pose, x, y);
        if (++seen % 2 == 0) half.See(pose, x, y);
      }
  const double density = SightingDensityPerM2(all.data());
  EXPECT_NEAR(density, 0.25, 0.04);  // measured 0.276
  EXPECT_NEAR(SightingDensityPerM2(half.data()), density / 2, 0.01);
  EXPECT_EQ(SightingDensityPerM2(Scans(3).data()), 0.0);  // no sighting
}

// A straight drive of unit steps with independent noise per step.
LandmarkDataset StraightDrive(int num_poses, const Eigen::Vector3d& step_std) {
  Scans scans(num_poses);
  LandmarkDataset data = scans.data();
  for (int i = 1; i < num_poses; ++i) {
    RelativePoseMeasurement m;
    m.from = i - 1;
    m.to = i;
    m.delta = {1.0, 0.0, 0.0};
    m.covariance = step_std.cwiseAbs2().asDiagonal();
    data.odometry.push_back(m);
  }
  LandmarkSighting s;
  s.range_m = 6.0;  // every sighting (the median range) 6 m away
  for (int i = 0; i < num_poses; ++i) {
    s.pose = i;
    data.sightings.push_back(s);
  }
  return data;
}

TEST(LandmarkTracksTest, WindowsEndWhereTheDriftReachesTheBound) {
  const Eigen::Vector3d step_std(0.02, 0.01, 0.01);
  const LandmarkDataset data = StraightDrive(100, step_std);
  // Closed form for k unit steps straight ahead: the heading error of step j
  // moves the k - j later steps sideways.
  const auto drift = [&](int k) {
    double lateral = k * step_std.y() * step_std.y();
    for (int j = 1; j < k; ++j) lateral += (k - j) * (k - j) * step_std.z() * step_std.z();
    const double along = k * step_std.x() * step_std.x();
    return std::sqrt(std::max(lateral, along) + 36.0 * k * step_std.z() * step_std.z());
  };
  const double bound = 0.5;
  int steps = 1;
  while (drift(steps) <= bound) ++steps;
  ASSERT_GT(steps, 5);
  ASSERT_LT(3 * steps, 100);
  const std::vector<int> ends = SearchWindowEnds(data, 0, bound);
  ASSERT_GE(ends.size(), 3u);
  EXPECT_EQ(ends[0], steps + 1);        // poses 0 .. steps
  EXPECT_EQ(ends[1] - ends[0], steps);  // from the pose before the window
  EXPECT_EQ(ends.back(), 100);
  // The pose cap still holds, and without a bound the windows are fixed.
  EXPECT_EQ(SearchWindowEnds(data, 5, bound).front(), 5);
  EXPECT_EQ(SearchWindowEnds(data, 40, 0.0), (std::vector<int>{40, 80, 100}));
  EXPECT_EQ(SearchWindowEnds(data, 0, 0.0), (std::vector<int>{100}));
}

}  // namespace
}  // namespace oslam
