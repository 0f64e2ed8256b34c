#include "association/landmark_tracks.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Core>

#include "core/angles.h"
#include "core/error.h"
#include "core/statistics.h"
#include "slam/landmark_factors.h"

namespace oslam {

bool LandmarkTrackOptions::Validate(std::string* why) const {
  if (!(gate_m > 0) || !std::isfinite(gate_m)) {
    if (why) *why = "the track gate must be > 0 m and finite";
    return false;
  }
  if (max_pose_gap < 1) {
    if (why) *why = "the track's pose gap must be >= 1";
    return false;
  }
  return true;
}

std::vector<std::vector<int>> BuildLandmarkTracks(const LandmarkDataset& data,
                                                  const std::vector<Pose2>& trajectory,
                                                  const LandmarkTrackOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("landmark tracks: " + why);
  if (static_cast<int>(trajectory.size()) != data.num_poses)
    throw Error("landmark tracks: the trajectory has " + std::to_string(trajectory.size()) +
                " poses for " + std::to_string(data.num_poses));
  std::vector<int> order;
  for (size_t k = 0; k < data.sightings.size(); ++k)
    if (data.sightings[k].range_m > 0) order.push_back(static_cast<int>(k));
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return data.sightings[a].pose < data.sightings[b].pose; });
  struct Active {
    int track, last_pose;
    Eigen::Vector2d last_m;
  };
  std::vector<std::vector<int>> tracks;
  std::vector<Active> active;
  const double gate2 = options.gate_m * options.gate_m;
  for (size_t begin = 0; begin < order.size();) {
    const int pose = data.sightings[order[begin]].pose;
    size_t end = begin;
    while (end < order.size() && data.sightings[order[end]].pose == pose) ++end;
    active.erase(
        std::remove_if(active.begin(), active.end(),
                       [&](const Active& a) { return pose - a.last_pose > options.max_pose_gap; }),
        active.end());
    const size_t n = end - begin;
    std::vector<Eigen::Vector2d> world(n);
    std::vector<int> claim(n, -1);  // index into `active`
    std::vector<int> claims(active.size(), 0);
    for (size_t i = 0; i < n; ++i) {
      const LandmarkSighting& s = data.sightings[order[begin + i]];
      world[i] = LandmarkFromRangeBearing(trajectory[pose], s.range_m, s.bearing_rad,
                                          data.sensor_offset_m);
      int candidates = 0;
      for (size_t a = 0; a < active.size(); ++a)
        if ((active[a].last_m - world[i]).squaredNorm() <= gate2) {
          ++candidates;
          claim[i] = static_cast<int>(a);
        }
      if (candidates != 1) claim[i] = -1;  // none, or ambiguous
      if (claim[i] >= 0) ++claims[claim[i]];
    }
    std::vector<Active> next;
    for (size_t i = 0; i < n; ++i) {
      const int k = order[begin + i];
      if (claim[i] >= 0 && claims[claim[i]] == 1) {
        Active& a = active[claim[i]];
        tracks[a.track].push_back(k);
        a.last_pose = pose;
        a.last_m = world[i];
      } else {
        tracks.push_back({k});
        next.push_back({static_cast<int>(tracks.size()) - 1, pose, world[i]});
      }
    }
    active.insert(active.end(), next.begin(), next.end());
    begin = end;
  }
  return tracks;
}

namespace {

// The odometry step reaching each pose from the one before (nullptr where
// the chain has none).
std::vector<const RelativePoseMeasurement*> ChainSteps(const LandmarkDataset& data) {
  std::vector<const RelativePoseMeasurement*> steps(static_cast<size_t>(data.num_poses), nullptr);
  for (const RelativePoseMeasurement& m : data.odometry)
    if (m.to == m.from + 1 && m.to < data.num_poses && !steps[static_cast<size_t>(m.to)])
      steps[static_cast<size_t>(m.to)] = &m;
  return steps;
}

}  // namespace

double MedianCoVisibleSpacing(const LandmarkDataset& data) {
  std::vector<std::vector<Eigen::Vector2d>> per_scan(static_cast<size_t>(data.num_poses));
  for (const LandmarkSighting& s : data.sightings)
    if (s.range_m > 0)
      per_scan[static_cast<size_t>(s.pose)].push_back(
          LandmarkFromRangeBearing(Pose2{}, s.range_m, s.bearing_rad, data.sensor_offset_m));
  std::vector<double> nearest;
  for (const auto& scan : per_scan) {
    if (scan.size() < 2) continue;
    for (size_t a = 0; a < scan.size(); ++a) {
      double best = std::numeric_limits<double>::infinity();
      for (size_t b = 0; b < scan.size(); ++b)
        if (b != a) best = std::min(best, (scan[a] - scan[b]).norm());
      nearest.push_back(best);
    }
  }
  return UpperMedian(std::move(nearest));
}

double SightingDensityPerM2(const LandmarkDataset& data) {
  std::vector<double> ranges, bearings;
  for (const LandmarkSighting& s : data.sightings) {
    if (!(s.range_m > 0)) continue;
    ranges.push_back(s.range_m);
    bearings.push_back(WrapAngle(s.bearing_rad));
  }
  if (ranges.empty() || data.num_poses <= 0) return 0.0;
  auto quantile = [](std::vector<double>* v, double q) {
    const size_t at = std::min(v->size() - 1, static_cast<size_t>(q * double(v->size())));
    std::nth_element(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(at), v->end());
    return (*v)[at];
  };
  const double near_m = quantile(&ranges, 0.01), far_m = quantile(&ranges, 0.99);
  const double view_rad = std::min(2 * kPi, quantile(&bearings, 0.99) - quantile(&bearings, 0.01));
  const double area_m2 = 0.5 * view_rad * (far_m * far_m - near_m * near_m);
  if (!(area_m2 > 0)) return 0.0;
  return double(ranges.size()) / double(data.num_poses) / area_m2;
}

std::vector<int> SearchWindowEnds(const LandmarkDataset& data, int max_poses, double max_drift_m) {
  std::vector<int> ends;
  const int n = data.num_poses;
  if (max_drift_m <= 0) {
    if (max_poses > 0)
      for (int end = max_poses; end < n; end += max_poses) ends.push_back(end);
    ends.push_back(n);
    return ends;
  }
  std::vector<double> ranges;
  for (const LandmarkSighting& s : data.sightings)
    if (s.range_m > 0) ranges.push_back(s.range_m);
  const double range_m = UpperMedian(std::move(ranges));
  const std::vector<const RelativePoseMeasurement*> steps = ChainSteps(data);
  // Pose k relative to the pose before the window, and its covariance there.
  Pose2 relative;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int start = 0;
  for (int k = 1; k < n; ++k) {
    if (const RelativePoseMeasurement* step = steps[static_cast<size_t>(k)]) {
      const double c = std::cos(relative.theta), s = std::sin(relative.theta);
      const Pose2& d = step->delta;
      Eigen::Matrix3d by_pose = Eigen::Matrix3d::Identity();
      by_pose(0, 2) = -s * d.x - c * d.y;
      by_pose(1, 2) = c * d.x - s * d.y;
      Eigen::Matrix3d by_step = Eigen::Matrix3d::Identity();
      by_step.topLeftCorner<2, 2>() << c, -s, s, c;
      covariance = by_pose * covariance * by_pose.transpose() +
                   by_step * step->covariance * by_step.transpose();
      relative = ComposePose(relative, d);
    }
    const Eigen::Matrix2d position = covariance.topLeftCorner<2, 2>();
    const double largest =
        0.5 * (position.trace() + std::hypot(position(0, 0) - position(1, 1), 2 * position(0, 1)));
    const double drift_m = std::sqrt(largest + range_m * range_m * covariance(2, 2));
    const bool full = max_poses > 0 && k + 1 - start >= max_poses;
    // Pose k goes into the window ending at k + 1; the next starts afresh.
    if ((drift_m > max_drift_m || full) && k + 1 < n) {
      ends.push_back(k + 1);
      start = k + 1;
      relative = Pose2{};
      covariance.setZero();
    }
  }
  ends.push_back(n);
  return ends;
}

}  // namespace oslam
