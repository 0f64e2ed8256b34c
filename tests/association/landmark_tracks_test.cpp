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

}  // namespace
}  // namespace oslam
