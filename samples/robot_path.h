// Drives the simulated robot: true poses and the odometry it reports, with
// the odometry error of the motion model (docs/method.md §4.1):
//   x_i = f(x_{i-1}, v_i) + e_i,   e_i ~ N(0, Q_i),   Q_i = MotionCovariance(v_i)
// where v_i is the reported increment. The robot moves stop-and-go, one
// command (a step or a turn) per frame, like the LPA robot.
#pragma once

#include <random>
#include <vector>

#include "core/motion_model.h"
#include "core/pose2.h"
#include "samples/scene.h"

namespace oslam {

struct DrivenPath {
  std::vector<Pose2> true_poses;              // one per frame
  std::vector<OdometryIncrement> increments;  // reported; increments[0] is zero
  std::vector<Pose2> odometry_poses;          // increments integrated from true_poses[0]
};

// Runs the path's commands (open loop) or steers towards its waypoints (closed
// loop on the true pose, as a remote-control driver watching the robot would).
// Stops after max_frames frames when max_frames > 0. Throws oslam::Error when
// the waypoints cannot be reached in a sane number of steps.
DrivenPath DrivePath(const PathSpec& spec, const OdometryNoise& noise, long max_frames,
                     std::mt19937_64& rng);

// The same drive filmed at `frames_per_step` frames per command, as a video
// of the robot moving at its own speed records it: frame k·n is the k-th stop
// of `path`, and the n − 1 frames before it lie on the motion from the stop
// before (a constant twist: a straight step, a turn on the spot or an arc),
// for the true and the odometry poses alike; each increment is split into n
// equal parts. frames_per_step = 1 returns the path unchanged.
DrivenPath FilmedAtFramesPerStep(const DrivenPath& path, int frames_per_step);

// One draw of e_i ~ N(0, Q_i) scaled by noise.scale (zero when the scale is 0).
Eigen::Vector3d SampleMotionError(double previous_heading_rad, const OdometryIncrement& increment,
                                  const OdometryNoise& noise, std::mt19937_64& rng);

// The options with every standard deviation multiplied by noise.scale: the Q
// the simulated odometry really has.
MotionNoiseOptions ScaledNoise(const OdometryNoise& noise);

}  // namespace oslam
