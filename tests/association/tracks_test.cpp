// Pre-association into tracks (eq. 6.1, Algorithm 9 steps 1-2).
#include "association/tracks.h"

#include <gtest/gtest.h>

#include "core/angles.h"
#include "core/error.h"

namespace oslam {
namespace {

ClassedSlice At(long frame, int c, double u_r, double u_phi_deg, double s_r = 40,
                double s_phi_deg = 10) {
  return {frame, c, {u_r, DegToRad(u_phi_deg), s_r, DegToRad(s_phi_deg)}};
}

TEST(TracksTest, GateHasTheFourThresholdsOfEq61) {
  TrackOptions o;
  const BoundingSlice a = At(0, 0, 200, 10).slice;
  EXPECT_TRUE(PassesTrackGate(a, At(1, 0, 229, 29).slice, o));
  EXPECT_FALSE(PassesTrackGate(a, At(1, 0, 231, 10).slice, o));      // |du_r| >= 30 px
  EXPECT_FALSE(PassesTrackGate(a, At(1, 0, 200, 31).slice, o));      // |du_phi| >= 20 deg
  EXPECT_FALSE(PassesTrackGate(a, At(1, 0, 200, 10, 49).slice, o));  // 9 >= 0.2 * 40
  EXPECT_FALSE(PassesTrackGate(a, At(1, 0, 200, 10, 40, 12.5).slice, o));
  // The angle gate wraps at +-180 degrees.
  EXPECT_TRUE(PassesTrackGate(At(0, 0, 200, 175).slice, At(1, 0, 200, -175).slice, o));
}

TEST(TracksTest, LinksSameClassNearestOneToOneAndDropsShortTracks) {
  std::vector<ClassedSlice> d;
  for (long f = 0; f < 5; ++f) {
    d.push_back(At(f, 0, 200 + 2 * f, 10 + f));  // object A, class 0
    d.push_back(At(f, 1, 200 + 2 * f, 12 + f));  // object B nearby, class 1
  }
  d.push_back(At(2, 0, 300, -90));  // a lone spurious detection
  d.push_back(At(3, 0, 205, 14));   // a second candidate for A at frame 3 (farther)
  TrackOptions options;
  options.min_length = 3;
  const TrackSet set = BuildTracks(d, options);
  ASSERT_EQ(set.tracks.size(), 2u);
  for (const Track& t : set.tracks) {
    EXPECT_EQ(t.detections.size(), 5u);
    for (int i : t.detections) EXPECT_EQ(d[i].class_index, t.class_index);
  }
  EXPECT_EQ(set.tracks[0].class_index, 0);  // ordered by first frame, then input order
  EXPECT_EQ(set.summary.num_dropped_detections, 2);
  EXPECT_GT(set.summary.num_ambiguous, 0);
  // Refusing ambiguous links breaks A's track at the ambiguity.
  options.link_rule = TrackLinkRule::kRefuseAmbiguous;
  options.min_length = 1;
  EXPECT_GT(BuildTracks(d, options).tracks.size(), 4u);
}

TEST(TracksTest, TracksSplitByAnOcclusionAreRejoinedAcrossTheGap) {
  // Object A (class 0) seen in frames 0-3, hidden in 4-5, seen again 6-9;
  // object B (class 1) at the same place, seen in frames 6-9 only; a class-0
  // object far away (C) appears in frame 6.
  std::vector<ClassedSlice> d;
  for (long f : {0, 1, 2, 3, 6, 7, 8, 9}) d.push_back(At(f, 0, 200 + 3 * f, 10 + 2 * f));
  for (long f : {6, 7, 8, 9}) d.push_back(At(f, 1, 200 + 3 * f, 10 + 2 * f));
  for (long f : {6, 7, 8}) d.push_back(At(f, 0, 150, -120));
  TrackOptions options;
  const TrackSet thesis = BuildTracks(d, options);
  EXPECT_EQ(thesis.tracks.size(), 4u);  // A in two pieces, B, C
  EXPECT_EQ(thesis.summary.num_gap_links, 0);
  options.max_gap_frames = 2;
  const TrackSet joined = BuildTracks(d, options);
  ASSERT_EQ(joined.tracks.size(), 3u);
  EXPECT_EQ(joined.tracks[0].detections.size(), 8u);  // A whole; never B (class) nor C (gate)
  for (int i : joined.tracks[0].detections) EXPECT_EQ(d[i].class_index, 0);
  EXPECT_EQ(d[joined.tracks[0].detections.back()].frame, 9);
  EXPECT_EQ(joined.summary.num_gap_links, 1);
  // A gap longer than the limit is not bridged.
  options.max_gap_frames = 1;
  EXPECT_EQ(BuildTracks(d, options).tracks.size(), 4u);
}

TEST(TracksTest, GapJoiningRescuesFragmentsShorterThanTheMinimum) {
  // 2 + 2 detections with one missed frame: dropped by N_min = 3 unless joined.
  const std::vector<ClassedSlice> d = {At(0, 0, 200, 10), At(1, 0, 202, 11), At(3, 0, 206, 13),
                                       At(4, 0, 208, 14)};
  TrackOptions options;
  EXPECT_TRUE(BuildTracks(d, options).tracks.empty());
  options.max_gap_frames = 1;
  const TrackSet set = BuildTracks(d, options);
  ASSERT_EQ(set.tracks.size(), 1u);
  EXPECT_EQ(set.tracks[0].detections, (std::vector<int>{0, 1, 2, 3}));
}

TEST(TracksTest, InvalidOptionsThrow) {
  TrackOptions options;
  options.min_length = 0;
  EXPECT_THROW(BuildTracks({}, options), Error);
  options.min_length = 1;
  options.max_gap_frames = -1;
  EXPECT_THROW(BuildTracks({}, options), Error);
}

}  // namespace
}  // namespace oslam
