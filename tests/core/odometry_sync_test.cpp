// Odometry matched to frames by time: SE(2) interpolation against motion
// with a known closed form, frames outside the odometry's span, and the
// frame selection by distance, turn or stride.
#include "core/odometry_sync.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/angles.h"
#include "core/error.h"
#include "core/motion_model.h"

namespace oslam {
namespace {

// A robot driving on a circle at 0.4 m/s, turning at 0.3 rad/s, from
// (1, 2) heading 0.5 rad: the pose at time t in closed form.
Pose2 OnArc(double t) {
  const double v = 0.4, w = 0.3, theta0 = 0.5;
  const double theta = theta0 + w * t;
  return {1.0 + v / w * (std::sin(theta) - std::sin(theta0)),
          2.0 - v / w * (std::cos(theta) - std::cos(theta0)), WrapAngle(theta)};
}

// Odometry sampled every `period` s from t0 to t1 (with a little jitter in
// the sampling times, as a real logger has; first and last rows at t0, t1).
TimedOdometry SampleArc(double t0, double t1, double period) {
  TimedOdometry odometry;
  int k = 0;
  for (double t = t0; t <= t1 + 1e-12; t = t0 + (++k) * period) {
    const double jitter = 0.1 * period * std::sin(7.0 * k);
    const double stamp = std::min(t1, std::max(t0, t + jitter));
    if (!odometry.stamps_s.empty() && stamp <= odometry.stamps_s.back()) continue;
    odometry.stamps_s.push_back(stamp);
    odometry.poses.push_back(OnArc(stamp));
  }
  // The span is exactly [t0, t1] whatever the jitter.
  odometry.stamps_s.front() = t0;
  odometry.poses.front() = OnArc(t0);
  if (odometry.stamps_s.back() < t1) {
    odometry.stamps_s.push_back(t1);
    odometry.poses.push_back(OnArc(t1));
  }
  return odometry;
}

TEST(OdometrySync, InterpolationIsExactOnAnArcAndAtTheRows) {
  const TimedOdometry odometry = SampleArc(0.0, 10.0, 0.1);  // 10 Hz
  for (double t = 0.0; t <= 10.0; t += 1.0 / 30) {           // 30 fps
    const Pose2 pose = InterpolateOdometry(odometry, t);
    const Pose2 truth = OnArc(t);
    EXPECT_NEAR(pose.x, truth.x, 1e-9) << t;
    EXPECT_NEAR(pose.y, truth.y, 1e-9) << t;
    EXPECT_NEAR(WrapAngle(pose.theta - truth.theta), 0.0, 1e-9) << t;
  }
  const Pose2 row = InterpolateOdometry(odometry, odometry.stamps_s[17]);
  EXPECT_EQ(row.x, odometry.poses[17].x);
  EXPECT_THROW(InterpolateOdometry(odometry, 10.5), Error);
}

// Linear interpolation of x, y and θ cuts the corners of an arc; the SE(2)
// interpolation does not: at 2 Hz odometry and 1 rad/s turning the
// difference is measurable.
TEST(OdometrySync, SlowOdometryStillFollowsTheArc) {
  TimedOdometry odometry;
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.5 * k;
    odometry.stamps_s.push_back(t);
    odometry.poses.push_back(
        {std::sin(t), 1.0 - std::cos(t), WrapAngle(t)});  // unit circle, 1 rad/s
  }
  const double t = 1.25;
  const Pose2 pose = InterpolateOdometry(odometry, t);
  EXPECT_NEAR(pose.x, std::sin(t), 1e-12);
  EXPECT_NEAR(pose.y, 1.0 - std::cos(t), 1e-12);
  const double linear_x = 0.5 * (std::sin(1.0) + std::sin(1.5));
  EXPECT_GT(std::abs(linear_x - std::sin(t)), 1e-2);  // what linear interpolation would give
}

TEST(OdometrySync, FramesOutsideTheSpanAreDroppedAndCounted) {
  // Odometry from 2 s to 8 s of the arc; frames at 30 fps from 0 to 10 s on
  // a clock 0.5 s behind the odometry's.
  const TimedOdometry odometry = SampleArc(2.0, 8.0, 1.0 / 20);
  std::vector<double> frame_times;
  for (int i = 0; i <= 300; ++i) frame_times.push_back(i / 30.0);
  FrameSelectionOptions options;
  options.time_offset_s = 0.5;
  options.stride = 1;
  const FrameSelection all = SelectFrames(odometry, frame_times, options);
  // Odometry time = frame time + 0.5 lies in [2, 8] for frame times in [1.5, 7.5].
  EXPECT_EQ(all.before_odometry, 45);  // frames 0..44 (t < 1.5)
  EXPECT_EQ(all.after_odometry, 75);   // frames 226..300 (t > 7.5)
  ASSERT_EQ(all.frames.size(), 181u);
  EXPECT_EQ(all.frames.front(), 45);
  EXPECT_EQ(all.thinned, 0);
  for (size_t k = 0; k < all.frames.size(); ++k) {
    const Pose2 truth = OnArc(all.times_s[k] + 0.5);
    EXPECT_NEAR(all.poses[k].x, truth.x, 1e-9);
    EXPECT_NEAR(all.poses[k].y, truth.y, 1e-9);
  }
  EXPECT_EQ(all.Summary(),
            "kept 181 of 301 frames (45 before and 75 after the odometry's span dropped, 0 "
            "thinned)");
  options.stride = 10;
  const FrameSelection strided = SelectFrames(odometry, frame_times, options);
  ASSERT_EQ(strided.frames.size(), 19u);  // 45, 55, ..., 225
  EXPECT_EQ(strided.frames[1], 55);
  EXPECT_EQ(strided.thinned, 181 - 19);
  options.time_offset_s = 20.0;
  EXPECT_THROW(SelectFrames(odometry, frame_times, options), Error);
}

TEST(OdometrySync, FramesAreKeptByDistanceOrTurn) {
  // Straight at 0.5 m/s for 4 s, then turning on the spot at 0.5 rad/s for 4 s.
  TimedOdometry odometry;
  for (int k = 0; k <= 80; ++k) {
    const double t = 0.1 * k;
    odometry.stamps_s.push_back(t);
    odometry.poses.push_back(t <= 4.0 ? Pose2{0.5 * t, 0.0, 0.0}
                                      : Pose2{2.0, 0.0, WrapAngle(0.5 * (t - 4.0))});
  }
  std::vector<double> frame_times;
  for (int i = 0; i <= 240; ++i) frame_times.push_back(i / 30.0);
  FrameSelectionOptions options;  // 0.2 m or 10°
  options.step_tolerance = 0.0;   // strict: this test checks the thresholds themselves
  const FrameSelection selection = SelectFrames(odometry, frame_times, options);
  // 2 m straight: a frame every 0.2 m (the first frame past each 0.2 m step);
  // 2 rad on the spot: a frame every 10°.
  int by_distance = 0, by_turn = 0;
  for (size_t k = 1; k < selection.frames.size(); ++k) {
    const Pose2& a = selection.poses[k - 1];
    const Pose2& b = selection.poses[k];
    const double moved = std::hypot(b.x - a.x, b.y - a.y);
    const double turned = std::abs(WrapAngle(b.theta - a.theta));
    EXPECT_TRUE(moved >= 0.2 || turned >= DegToRad(10.0)) << k;
    // Not later than one frame past the threshold (0.5 m/s, 0.5 rad/s at 30 fps).
    EXPECT_TRUE(moved < 0.2 + 0.5 / 30 + 1e-9 && turned < DegToRad(10.0) + 0.5 / 30 + 1e-9) << k;
    by_distance += moved >= 0.2;
    by_turn += turned >= DegToRad(10.0) && moved < 0.2;
  }
  // 2 m / 0.2 m = 10 steps and 2 rad / 10° = 11.5, fewer by the overshoot of
  // up to a frame per step.
  EXPECT_GE(by_distance, 9);
  EXPECT_LE(by_distance, 10);
  EXPECT_GE(by_turn, 10);
  EXPECT_LE(by_turn, 11);
  EXPECT_EQ(selection.frames.size() + selection.thinned, 241u);
}

// A stop-and-go robot like the thesis': steps of exactly 0.2 m or 10°, the
// odometry integrated from the commanded increments and logged at each stop
// on a clock 0.3 s ahead, one frame per stop. Integration leaves about half
// of the steps a hair short of 0.2 m (0.19999...), which a strict threshold
// dropped; with the default tolerance every stop is kept, and steps clearly
// shorter are still thinned.
TimedOdometry StopAndGo(double step_m, double turn_rad, int stops, double frame_period_s) {
  TimedOdometry odometry;
  Pose2 pose{-1.8, -1.8, 0.0};
  for (int k = 0; k < stops; ++k) {
    if (k > 0) {
      const bool turn = k % 5 == 4;  // four steps forward, one turn
      pose = ApplyIncrement(pose, {turn ? 0.0 : step_m, turn ? turn_rad : 0.0});
    }
    odometry.stamps_s.push_back(k * frame_period_s + 0.3);
    odometry.poses.push_back(pose);
  }
  return odometry;
}

TEST(OdometrySync, StopAndGoStepsOfExactlyTheThresholdAreAllKept) {
  const double period = 1.0 / 30.0;
  const int stops = 200;
  std::vector<double> frame_times;
  for (int i = 0; i < stops; ++i) frame_times.push_back(i * period);
  FrameSelectionOptions options;  // 0.2 m or 10°, default tolerance
  options.time_offset_s = 0.3;
  const TimedOdometry exact = StopAndGo(0.2, DegToRad(10.0), stops, period);
  const FrameSelection kept = SelectFrames(exact, frame_times, options);
  EXPECT_EQ(kept.frames.size(), static_cast<size_t>(stops)) << kept.Summary();
  EXPECT_EQ(kept.thinned, 0);
  // Steps a little short of the threshold, as encoders log them: kept too.
  const TimedOdometry short_steps = StopAndGo(0.197, DegToRad(9.8), stops, period);
  EXPECT_EQ(SelectFrames(short_steps, frame_times, options).frames.size(),
            static_cast<size_t>(stops));
  // Half-size steps are no stops of the selection: of every five stops (four
  // half steps and a half turn) two are kept, where two half steps add up to
  // the distance.
  const FrameSelection halves =
      SelectFrames(StopAndGo(0.1, DegToRad(5.0), stops, period), frame_times, options);
  EXPECT_EQ(halves.frames.size(), static_cast<size_t>(2 * stops / 5));
  // Strict thresholds (no tolerance) show the rounding this guards against.
  options.step_tolerance = 0.0;
  EXPECT_LT(SelectFrames(exact, frame_times, options).frames.size(), static_cast<size_t>(stops));
  options.step_tolerance = 1.0;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(why.find("frames.step_tolerance"), std::string::npos) << why;
}

}  // namespace
}  // namespace oslam
