#include "samples/robot_path.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <Eigen/Cholesky>

#include "core/bounds.h"
#include "core/error.h"
#include "core/odometry_sync.h"

namespace oslam {

MotionNoiseOptions ScaledNoise(const OdometryNoise& noise) {
  MotionNoiseOptions options = noise.model;
  // Variances scale with the square of a standard-deviation factor.
  const double factor = options.entries_are_variances ? noise.scale * noise.scale : noise.scale;
  options.additive_std *= factor;
  options.multiplicative *= factor;
  return options;
}

Eigen::Vector3d SampleMotionError(double previous_heading_rad, const OdometryIncrement& increment,
                                  const OdometryNoise& noise, std::mt19937_64& rng) {
  if (noise.scale == 0.0) return Eigen::Vector3d::Zero();
  const Eigen::Matrix3d q = MotionCovariance(previous_heading_rad, increment, ScaledNoise(noise));
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector3d standard;
  for (int k = 0; k < 3; ++k) standard[k] = normal(rng);
  return q.llt().matrixL() * standard;
}

namespace {

// Appends one stop-and-go step. The robot executes the command with some
// jitter, which the encoders measure (the reported increment v_i); the true
// pose is f(x_{i-1}, v_i) plus the motion error e_i ~ N(0, Q(v_i)), exactly
// the model O-SLAM assumes.
void Step(const PathSpec& spec, OdometryIncrement command, const OdometryNoise& noise,
          std::mt19937_64& rng, DrivenPath* path) {
  std::normal_distribution<double> normal(0.0, 1.0);
  if (command.distance_m != 0.0) command.distance_m += spec.step_jitter_m * normal(rng);
  if (command.turn_rad != 0.0) command.turn_rad += spec.turn_jitter_rad * normal(rng);
  const Pose2& previous = path->true_poses.back();
  const Eigen::Vector3d error = SampleMotionError(previous.theta, command, noise, rng);
  path->true_poses.push_back(Pose2::FromVector(ApplyIncrement(previous, command).Vector() + error));
  path->increments.push_back(command);
  path->odometry_poses.push_back(ApplyIncrement(path->odometry_poses.back(), command));
}

// Full at max_frames (when > 0); a path longer than the frame bound is an
// error, so that no scene drives forever.
bool Full(const DrivenPath& path, long max_frames) {
  const long frames = static_cast<long>(path.true_poses.size());
  if (max_frames <= 0 && frames >= bounds::kFrames)
    throw Error("path: more than " + std::to_string(bounds::kFrames) +
                " frames (docs/formats.md, Bounds)");
  return max_frames > 0 && frames >= max_frames;
}

void RunCommands(const PathSpec& spec, const OdometryNoise& noise, long max_frames,
                 std::mt19937_64& rng, DrivenPath* path) {
  const std::string& text = spec.commands;
  size_t i = 0;
  while (i < text.size() && !Full(*path, max_frames)) {
    const char letter = text[i++];
    if (letter == ' ' || letter == ',') continue;
    long count = 0;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])))
      count = std::min(count * 10 + (text[i++] - '0'), bounds::kFrames);
    if (count == 0) count = 1;
    OdometryIncrement command;
    if (letter == 'F') command.distance_m = spec.step_m;
    if (letter == 'B') command.distance_m = -spec.step_m;
    if (letter == 'L') command.turn_rad = spec.turn_step_rad;
    if (letter == 'R') command.turn_rad = -spec.turn_step_rad;
    for (long k = 0; k < count && !Full(*path, max_frames); ++k)
      Step(spec, command, noise, rng, path);
  }
}

// The driver's choice at the true pose: turn towards the waypoint until it is
// within half a turn step of straight ahead, then drive one step.
OdometryIncrement SteerTowards(const Pose2& pose, const Eigen::Vector2d& target,
                               const PathSpec& spec) {
  const double bearing = std::atan2(target.y() - pose.y, target.x() - pose.x);
  const double error = WrapAngle(bearing - pose.theta);
  OdometryIncrement command;
  if (std::abs(error) > 0.5 * spec.turn_step_rad)
    command.turn_rad = error > 0 ? spec.turn_step_rad : -spec.turn_step_rad;
  else
    command.distance_m = spec.step_m;
  return command;
}

void FollowWaypoints(const PathSpec& spec, const OdometryNoise& noise, long max_frames,
                     std::mt19937_64& rng, DrivenPath* path) {
  // Reached = closer than 3/4 step, so one more step cannot overshoot by more.
  const double reach_m = 0.75 * spec.step_m;
  double planned_m = 0.0;
  Eigen::Vector2d from(spec.start.x, spec.start.y);
  for (const Eigen::Vector2d& w : spec.waypoints) planned_m += (w - from).norm(), from = w;
  // Generous: a path needing 20x its planned steps plus turning is lost.
  const double steps = 200.0 + 20.0 * planned_m / spec.step_m + 40.0 * spec.waypoints.size();
  const long step_limit = static_cast<long>(std::min(steps, double(bounds::kFrames)));
  size_t next = 0;
  while (next < spec.waypoints.size() && !Full(*path, max_frames)) {
    const Pose2& pose = path->true_poses.back();
    const Eigen::Vector2d& target = spec.waypoints[next];
    if (std::hypot(target.x() - pose.x, target.y() - pose.y) < reach_m) {
      ++next;
      continue;
    }
    if (static_cast<long>(path->true_poses.size()) > step_limit)
      throw Error("path: waypoint " + std::to_string(next) + " not reached after " +
                  std::to_string(step_limit) + " steps (step_m too large, or noise too high?)");
    Step(spec, SteerTowards(pose, target, spec), noise, rng, path);
  }
}

}  // namespace

DrivenPath DrivePath(const PathSpec& spec, const OdometryNoise& noise, long max_frames,
                     std::mt19937_64& rng) {
  DrivenPath path;
  path.true_poses.push_back(spec.start);
  path.increments.push_back(OdometryIncrement{});
  path.odometry_poses.push_back(spec.start);
  if (spec.commands.empty())
    FollowWaypoints(spec, noise, max_frames, rng, &path);
  else
    RunCommands(spec, noise, max_frames, rng, &path);
  return path;
}

DrivenPath FilmedAtFramesPerStep(const DrivenPath& path, int frames_per_step) {
  if (frames_per_step <= 1 || path.true_poses.size() < 2) return path;
  TimedOdometry truth, odometry;  // stamped by stop index
  for (size_t i = 0; i < path.true_poses.size(); ++i) {
    truth.stamps_s.push_back(static_cast<double>(i));
    odometry.stamps_s.push_back(static_cast<double>(i));
  }
  truth.poses = path.true_poses;
  odometry.poses = path.odometry_poses;
  DrivenPath filmed;
  filmed.true_poses.push_back(path.true_poses.front());
  filmed.odometry_poses.push_back(path.odometry_poses.front());
  filmed.increments.push_back(path.increments.front());
  for (size_t i = 1; i < path.true_poses.size(); ++i) {
    const OdometryIncrement part = {path.increments[i].distance_m / frames_per_step,
                                    path.increments[i].turn_rad / frames_per_step};
    for (int k = 1; k <= frames_per_step; ++k) {
      const double t = static_cast<double>(i - 1) + static_cast<double>(k) / frames_per_step;
      // The stop itself is copied, not interpolated: bit for bit the same poses.
      filmed.true_poses.push_back(k == frames_per_step ? path.true_poses[i]
                                                       : InterpolateOdometry(truth, t));
      filmed.odometry_poses.push_back(k == frames_per_step ? path.odometry_poses[i]
                                                           : InterpolateOdometry(odometry, t));
      filmed.increments.push_back(part);
    }
  }
  return filmed;
}

}  // namespace oslam
