#include "core/odometry_sync.h"

#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "core/error.h"

namespace oslam {
namespace {

// V(θ) of the SE(2) exponential: translation = V(θ) ρ for the twist (ρ, θ).
// Series near θ = 0, where sin θ / θ and (1 − cos θ) / θ lose precision.
void LeftJacobian(double theta, double* a, double* b) {
  if (std::abs(theta) < 1e-6) {
    *a = 1.0 - theta * theta / 6.0;
    *b = theta / 2.0;
  } else {
    *a = std::sin(theta) / theta;
    *b = (1.0 - std::cos(theta)) / theta;
  }
}

}  // namespace

Pose2 InterpolateOdometry(const TimedOdometry& odometry, double t_s) {
  const std::vector<double>& stamps = odometry.stamps_s;
  if (stamps.empty() || t_s < stamps.front() || t_s > stamps.back())
    throw Error("odometry interpolation: time " + std::to_string(t_s) + " s is outside the rows");
  const size_t upper =
      static_cast<size_t>(std::upper_bound(stamps.begin(), stamps.end(), t_s) - stamps.begin());
  if (upper == stamps.size()) return odometry.poses.back();
  const size_t lower = upper - 1;
  const Pose2& from = odometry.poses[lower];
  const Pose2& to = odometry.poses[upper];
  const double s = (t_s - stamps[lower]) / (stamps[upper] - stamps[lower]);
  // Relative motion in the frame of `from`, its twist (log), scaled by s,
  // mapped back (exp) and composed onto `from`.
  const double c = std::cos(from.theta), si = std::sin(from.theta);
  const double dx = c * (to.x - from.x) + si * (to.y - from.y);
  const double dy = -si * (to.x - from.x) + c * (to.y - from.y);
  const double dtheta = WrapAngle(to.theta - from.theta);
  double a = 0, b = 0;
  LeftJacobian(dtheta, &a, &b);
  const double det = a * a + b * b;  // V = [a −b; b a], V⁻¹ = [a b; −b a] / det
  const double rho_x = (a * dx + b * dy) / det, rho_y = (-b * dx + a * dy) / det;
  const double theta_s = s * dtheta;
  LeftJacobian(theta_s, &a, &b);
  const double tx = s * (a * rho_x - b * rho_y), ty = s * (b * rho_x + a * rho_y);
  return {from.x + c * tx - si * ty, from.y + si * tx + c * ty, WrapAngle(from.theta + theta_s)};
}

bool FrameSelectionOptions::Validate(std::string* why) const {
  auto fail = [why](const std::string& what) {
    if (why) *why = what;
    return false;
  };
  if (!std::isfinite(time_offset_s)) return fail("frames.time_offset_s must be finite");
  if (!(min_distance_m >= 0) || !std::isfinite(min_distance_m))
    return fail("frames.min_distance_m must be >= 0");
  if (!(min_turn_rad >= 0) || !std::isfinite(min_turn_rad))
    return fail("frames.min_turn_rad must be >= 0");
  if (!(step_tolerance >= 0 && step_tolerance < 1))
    return fail("frames.step_tolerance must be in [0, 1)");
  if (stride < 0) return fail("frames.stride must be >= 0 (0: by distance and turn)");
  return true;
}

std::string FrameSelection::Summary() const {
  const long total = static_cast<long>(frames.size()) + before_odometry + after_odometry + thinned;
  return "kept " + std::to_string(frames.size()) + " of " + std::to_string(total) + " frames (" +
         std::to_string(before_odometry) + " before and " + std::to_string(after_odometry) +
         " after the odometry's span dropped, " + std::to_string(thinned) + " thinned)";
}

FrameSelection SelectFrames(const TimedOdometry& odometry, const std::vector<double>& frame_times_s,
                            const FrameSelectionOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error(why);
  if (odometry.stamps_s.size() != odometry.poses.size() || odometry.stamps_s.size() < 2)
    throw Error("odometry by time needs at least two rows");
  FrameSelection selection;
  long in_span = 0;
  for (size_t i = 0; i < frame_times_s.size(); ++i) {
    if (i > 0 && !(frame_times_s[i] > frame_times_s[i - 1]))
      throw Error("frame times must increase (frame " + std::to_string(i) + ")");
    const double t = frame_times_s[i] + options.time_offset_s;
    if (t < odometry.stamps_s.front()) {
      ++selection.before_odometry;
      continue;
    }
    if (t > odometry.stamps_s.back()) {
      ++selection.after_odometry;
      continue;
    }
    const Pose2 pose = InterpolateOdometry(odometry, t);
    bool keep = selection.frames.empty();
    if (!keep && options.stride > 0) {
      keep = in_span % options.stride == 0;
    } else if (!keep) {
      const Pose2& last = selection.poses.back();
      const double reach = 1.0 - options.step_tolerance;
      keep = std::hypot(pose.x - last.x, pose.y - last.y) >= reach * options.min_distance_m ||
             std::abs(WrapAngle(pose.theta - last.theta)) >= reach * options.min_turn_rad;
    }
    ++in_span;
    if (!keep) {
      ++selection.thinned;
      continue;
    }
    selection.frames.push_back(static_cast<long>(i));
    selection.times_s.push_back(frame_times_s[i]);
    selection.poses.push_back(pose);
  }
  if (selection.frames.empty())
    throw Error("no frame lies within the odometry's time span (check frames.time_offset_s)");
  return selection;
}

}  // namespace oslam
