// Odometry logged at its own rate, matched to the frames by time, and the
// frames a run keeps of a video (docs/formats.md, "Odometry by time").
#pragma once

#include <string>
#include <vector>

#include "core/pose2.h"

namespace oslam {

// Integrated odometry poses at strictly increasing times (seconds, the
// odometry's clock).
struct TimedOdometry {
  std::vector<double> stamps_s;
  std::vector<Pose2> poses;
};

// The odometry pose at time `t_s` (within the rows' span): SE(2)
// interpolation between the rows around it, i.e. the robot moving with a
// constant velocity twist (forward, lateral, turn rate) between two rows;
// exact at the rows and for motion on a circular arc or a line.
Pose2 InterpolateOdometry(const TimedOdometry& odometry, double t_s);

struct FrameSelectionOptions {
  // Odometry time of a frame = frame time + offset (the two clocks' offset).
  double time_offset_s = 0.0;
  // Keep a frame once the robot has moved at least this far, or turned at
  // least this much, since the last kept frame (the thesis' stop-and-go
  // images: one every few decimetres); the first frame in the span is kept.
  double min_distance_m = 0.2;
  double min_turn_rad = 0.17453292519943295;  // 10°
  // A step counts as reaching the distance or turn when it is at least
  // (1 - step_tolerance) of it: a stop-and-go robot commanded 0.2 m steps
  // logs steps of 0.2 m give or take rounding (0.19999... after integration
  // and interpolation) and encoder ticks, which a strict >= would drop.
  double step_tolerance = 0.05;
  // > 0: keep every stride-th frame in the span instead (1: all).
  long stride = 0;

  bool Validate(std::string* why) const;
};

struct FrameSelection {
  std::vector<long> frames;     // kept frames (indices into the source), increasing
  std::vector<double> times_s;  // their times (frame clock)
  std::vector<Pose2> poses;     // their interpolated odometry poses
  long before_odometry = 0;     // frames dropped: earlier than the odometry's first row
  long after_odometry = 0;      // frames dropped: later than its last row
  long thinned = 0;             // frames in the span not kept (distance/turn or stride)

  // "kept 45 of 450 frames (3 before and 0 after the odometry's span dropped, 402 thinned)".
  std::string Summary() const;
};

// Throws oslam::Error when no frame lies in the odometry's span or the
// inputs are not increasing.
FrameSelection SelectFrames(const TimedOdometry& odometry, const std::vector<double>& frame_times_s,
                            const FrameSelectionOptions& options);

}  // namespace oslam
