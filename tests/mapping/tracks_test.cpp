// Pre-association into tracks (spec eq. 6.1, Algorithm 9 steps 1-2).
#include "mapping/tracks.h"

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

TEST(TracksTest, InvalidOptionsThrow) {
  TrackOptions options;
  options.min_length = 0;
  EXPECT_THROW(BuildTracks({}, options), Error);
}

}  // namespace
}  // namespace oslam
