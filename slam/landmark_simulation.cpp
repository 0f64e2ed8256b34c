#include "slam/landmark_simulation.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <unordered_map>

#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/csv.h"
#include "core/error.h"
#include "slam/landmark_factors.h"

namespace oslam {

bool LandmarkWorldOptions::Validate(std::string* why) const {
  auto fail = [&](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (num_poses < 2) return fail("a world needs at least 2 poses");
  if (num_landmarks < 0) return fail("the number of landmarks must be >= 0");
  if (!(step_m > 0) || !std::isfinite(step_m)) return fail("the step must be > 0");
  if (blocks < 1 || !(block_m > 0) || !std::isfinite(block_m))
    return fail("the world needs >= 1 block of positive size");
  if (!(street_offset_min_m >= 0) || !(street_offset_max_m >= street_offset_min_m) ||
      !(2 * street_offset_max_m < block_m))
    return fail("need 0 <= street offsets and twice the largest below the block size");
  if (!(min_separation_m >= 0)) return fail("the landmark separation must be >= 0");
  if (!(lattice_m >= 0) || !std::isfinite(lattice_m)) return fail("the lattice must be >= 0 m");
  if (lattice_m > 0 && layout != LandmarkWorldLayout::kCityGrid)
    return fail("a landmark lattice needs the city layout");
  if (!(max_range_m > 0) || !(field_of_view_rad > 0) || field_of_view_rad > 2 * kPi)
    return fail("the sensor needs a range > 0 and a field of view in (0, 2 pi]");
  if (!(range_std_m > 0) || !(bearing_std_rad > 0) || !std::isfinite(range_std_m) ||
      !std::isfinite(bearing_std_rad))
    return fail("the sighting noise must be > 0 and finite");
  if (!(detection_probability > 0) || detection_probability > 1)
    return fail("the detection probability must be in (0, 1]");
  if (!(clutter_per_scan >= 0) || !std::isfinite(clutter_per_scan))
    return fail("the clutter rate must be >= 0");
  if (!(odometry_std.minCoeff() > 0) || !odometry_std.allFinite())
    return fail("the odometry noise must be > 0 and finite");
  return true;
}

namespace {

// The true path: poses step_m apart. City grid: along the streets from
// crossing to crossing, turning at random at each; park: a heading that
// wanders, steered back inside near the border.
std::vector<Pose2> TruePath(const LandmarkWorldOptions& o, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Pose2> poses;
  poses.reserve(o.num_poses);
  const double side = o.blocks * o.block_m;
  if (o.layout == LandmarkWorldLayout::kCityGrid) {
    // Start at a crossing, heading east; crossings at multiples of block_m.
    int cx = o.blocks / 2, cy = o.blocks / 2, direction = 0;  // 0 E, 1 N, 2 W, 3 S
    const int dx[4] = {1, 0, -1, 0}, dy[4] = {0, 1, 0, -1};
    Pose2 pose{cx * o.block_m, cy * o.block_m, 0.0};
    double along = 0;  // metres driven from the last crossing
    while (static_cast<int>(poses.size()) < o.num_poses) {
      poses.push_back(pose);
      along += o.step_m;
      if (along >= o.block_m - 1e-9) {  // at the next crossing: choose the way on
        cx += dx[direction];
        cy += dy[direction];
        std::vector<int> ways;
        for (int turn : {0, 1, 3}) {  // on, left, right
          const int d = (direction + turn) % 4;
          const int nx = cx + dx[d], ny = cy + dy[d];
          if (nx >= 0 && ny >= 0 && nx <= o.blocks && ny <= o.blocks) ways.push_back(d);
        }
        if (ways.empty()) ways.push_back((direction + 2) % 4);  // a dead end: back
        direction = ways[std::uniform_int_distribution<size_t>(0, ways.size() - 1)(rng)];
        along = 0;
        pose = {cx * o.block_m, cy * o.block_m, WrapAngle(direction * kPi / 2)};
      } else {
        pose = {cx * o.block_m + dx[direction] * along, cy * o.block_m + dy[direction] * along,
                pose.theta};
      }
    }
  } else {
    std::normal_distribution<double> normal(0.0, 1.0);
    Pose2 pose{side / 2, side / 2, 0.0};
    double turn_rate = 0;  // rad per metre
    const double margin = std::min(side / 4, 2 * o.max_range_m);
    while (static_cast<int>(poses.size()) < o.num_poses) {
      poses.push_back(pose);
      // A slowly changing curvature (radius >= 10 m); near the border, turn
      // towards the centre.
      turn_rate = std::clamp(0.95 * turn_rate + 0.01 * normal(rng), -0.1, 0.1);
      double rate = turn_rate;
      const bool near_border =
          pose.x < margin || pose.y < margin || pose.x > side - margin || pose.y > side - margin;
      if (near_border) {
        const double to_centre = std::atan2(side / 2 - pose.y, side / 2 - pose.x);
        const double error = WrapAngle(to_centre - pose.theta);
        if (std::abs(error) > kPi / 3) rate = error > 0 ? 0.1 : -0.1;
      }
      pose = ComposePose(pose, {o.step_m, 0.0, rate * o.step_m});
    }
  }
  return poses;
}

// City grid on a lattice: num_landmarks of the lattice points within the
// street offsets, at random.
std::vector<Eigen::Vector2d> LatticeLandmarks(const LandmarkWorldOptions& o, std::mt19937_64& rng) {
  const double side = o.blocks * o.block_m;
  const auto to_street = [&](double v) {
    const double r = std::fmod(v, o.block_m);
    return std::min(r, o.block_m - r);
  };
  std::vector<Eigen::Vector2d> points;
  const int n = static_cast<int>(std::floor(side / o.lattice_m + 1e-9));
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const Eigen::Vector2d p(i * o.lattice_m, j * o.lattice_m);
      const double d = std::min(to_street(p.x()), to_street(p.y()));
      if (d >= o.street_offset_min_m && d <= o.street_offset_max_m) points.push_back(p);
    }
  if (static_cast<int>(points.size()) < o.num_landmarks)
    throw Error("landmark world: room for only " + std::to_string(points.size()) + " of " +
                std::to_string(o.num_landmarks) + " landmarks on a " + std::to_string(o.lattice_m) +
                " m lattice");
  std::shuffle(points.begin(), points.end(), rng);
  points.resize(static_cast<size_t>(o.num_landmarks));
  return points;
}

// Landmarks at least min_separation_m apart: beside the streets, or
// anywhere in the park.
std::vector<Eigen::Vector2d> PlaceLandmarks(const LandmarkWorldOptions& o, std::mt19937_64& rng) {
  if (o.lattice_m > 0) return LatticeLandmarks(o, rng);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double side = o.blocks * o.block_m;
  std::vector<Eigen::Vector2d> landmarks;
  // A hash grid of cells min_separation_m wide for the spacing test.
  const double cell = std::max(o.min_separation_m, 1e-3);
  std::unordered_map<long long, std::vector<int>> grid;
  auto key = [&](long long i, long long j) { return i * 1000003LL + j; };
  auto clear = [&](const Eigen::Vector2d& p) {
    const long long i = std::floor(p.x() / cell), j = std::floor(p.y() / cell);
    for (long long a = i - 1; a <= i + 1; ++a)
      for (long long b = j - 1; b <= j + 1; ++b) {
        const auto found = grid.find(key(a, b));
        if (found == grid.end()) continue;
        for (int k : found->second)
          if ((landmarks[k] - p).norm() < o.min_separation_m) return false;
      }
    return true;
  };
  const long long attempts = 200LL * std::max(1, o.num_landmarks) + 10000;
  for (long long attempt = 0;
       attempt < attempts && static_cast<int>(landmarks.size()) < o.num_landmarks; ++attempt) {
    Eigen::Vector2d p;
    if (o.layout == LandmarkWorldLayout::kCityGrid) {
      // A street (horizontal or vertical line of crossings), a point along
      // it, a side and an offset.
      const int line = std::uniform_int_distribution<int>(0, o.blocks)(rng);
      const double t = side * uniform(rng);
      const double offset =
          (uniform(rng) < 0.5 ? -1 : 1) *
          (o.street_offset_min_m + (o.street_offset_max_m - o.street_offset_min_m) * uniform(rng));
      p = uniform(rng) < 0.5 ? Eigen::Vector2d(t, line * o.block_m + offset)
                             : Eigen::Vector2d(line * o.block_m + offset, t);
    } else {
      p = Eigen::Vector2d(side * uniform(rng), side * uniform(rng));
    }
    if (!clear(p)) continue;
    grid[key(std::floor(p.x() / cell), std::floor(p.y() / cell))].push_back(
        static_cast<int>(landmarks.size()));
    landmarks.push_back(p);
  }
  if (static_cast<int>(landmarks.size()) < o.num_landmarks)
    throw Error("landmark world: room for only " + std::to_string(landmarks.size()) + " of " +
                std::to_string(o.num_landmarks) + " landmarks " +
                std::to_string(o.min_separation_m) + " m apart");
  return landmarks;
}

}  // namespace

LandmarkWorld SimulateLandmarkWorld(const LandmarkWorldOptions& o) {
  std::string why;
  if (!o.Validate(&why)) throw Error("landmark world options: " + why);
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  LandmarkWorld world;
  world.true_trajectory = TruePath(o, rng);
  world.true_landmarks = PlaceLandmarks(o, rng);
  LandmarkDataset& data = world.data;
  data.path = "simulated";
  data.format = "simulated";
  data.has_landmark_ids = true;
  data.num_poses = o.num_poses;
  for (int i = 0; i < o.num_poses; ++i) data.pose_ids.push_back(i);
  // Odometry: the true increment plus noise of the stated covariance. The
  // first pose is the frame of the data set: dead reckoning starts there.
  const Eigen::Matrix3d covariance = o.odometry_std.cwiseAbs2().asDiagonal();
  data.dead_reckoning.push_back({0, 0, 0});
  const Pose2 origin = world.true_trajectory.front();
  for (Pose2& p : world.true_trajectory) p = BetweenPoses(origin, p);
  for (Eigen::Vector2d& l : world.true_landmarks) {
    const Eigen::Vector3d local = origin.WorldToRobot(Eigen::Vector3d(l.x(), l.y(), 0));
    l = local.head<2>();
  }
  for (int i = 1; i < o.num_poses; ++i) {
    const Pose2 d = BetweenPoses(world.true_trajectory[i - 1], world.true_trajectory[i]);
    RelativePoseMeasurement edge;
    edge.from = i - 1;
    edge.to = i;
    edge.delta = {d.x + o.odometry_std.x() * normal(rng), d.y + o.odometry_std.y() * normal(rng),
                  WrapAngle(d.theta + o.odometry_std.z() * normal(rng))};
    edge.covariance = covariance;
    data.odometry.push_back(edge);
    data.dead_reckoning.push_back(ComposePose(data.dead_reckoning.back(), edge.delta));
  }
  // Sightings: landmarks in view (a hash grid of max_range cells), detected
  // with detection_probability; clutter uniform over the view.
  const double cell = o.max_range_m;
  std::unordered_map<long long, std::vector<int>> grid;
  auto key = [](long long i, long long j) { return i * 1000003LL + j; };
  for (size_t id = 0; id < world.true_landmarks.size(); ++id) {
    const Eigen::Vector2d& l = world.true_landmarks[id];
    grid[key(std::floor(l.x() / cell), std::floor(l.y() / cell))].push_back(static_cast<int>(id));
  }
  std::poisson_distribution<int> clutter(o.clutter_per_scan);
  int next_clutter_id = o.num_landmarks;
  for (int i = 0; i < o.num_poses; ++i) {
    const Pose2& pose = world.true_trajectory[i];
    const long long ci = std::floor(pose.x / cell), cj = std::floor(pose.y / cell);
    std::vector<int> seen;
    for (long long a = ci - 1; a <= ci + 1; ++a)
      for (long long b = cj - 1; b <= cj + 1; ++b) {
        const auto found = grid.find(key(a, b));
        if (found != grid.end())
          seen.insert(seen.end(), found->second.begin(), found->second.end());
      }
    std::sort(seen.begin(), seen.end());  // the same order whatever the hashing
    auto add = [&](int id, int truth, double range, double bearing) {
      LandmarkSighting s;
      s.pose = i;
      s.landmark = id;
      s.range_m = range;
      s.bearing_rad = WrapAngle(bearing);
      s.range_std_m = o.range_std_m;
      s.bearing_std_rad = o.bearing_std_rad;
      data.sightings.push_back(s);
      world.true_association.push_back(truth);
    };
    for (int id : seen) {
      const Eigen::Vector2d d = world.true_landmarks[id] - Eigen::Vector2d(pose.x, pose.y);
      const double range = d.norm(), bearing = WrapAngle(std::atan2(d.y(), d.x()) - pose.theta);
      if (range > o.max_range_m || std::abs(bearing) > o.field_of_view_rad / 2) continue;
      if (uniform(rng) >= o.detection_probability) continue;
      const double noisy_range = range + o.range_std_m * normal(rng);
      if (!(noisy_range > 0)) continue;
      add(id, id, noisy_range, bearing + o.bearing_std_rad * normal(rng));
    }
    for (int c = clutter(rng); c > 0; --c)
      add(next_clutter_id++, -1, o.max_range_m * std::sqrt(std::max(1e-6, uniform(rng))),
          o.field_of_view_rad * (uniform(rng) - 0.5));
  }
  return world;
}

void WriteLandmarkWorldTruth(const LandmarkWorld& world, const std::string& trajectory_csv,
                             const std::string& landmarks_csv, const std::string& association_txt) {
  std::ostringstream t, l, a;
  t << "pose,x_m,y_m,theta_rad\n";
  for (size_t i = 0; i < world.true_trajectory.size(); ++i) {
    const Pose2& p = world.true_trajectory[i];
    t << i << ',' << CsvNumber(p.x) << ',' << CsvNumber(p.y) << ',' << CsvNumber(p.theta) << '\n';
  }
  l << "id,x_m,y_m\n";
  for (size_t id = 0; id < world.true_landmarks.size(); ++id)
    l << id << ',' << CsvNumber(world.true_landmarks[id].x()) << ','
      << CsvNumber(world.true_landmarks[id].y()) << '\n';
  for (int id : world.true_association) a << id << '\n';
  WriteTextFileAtomically(trajectory_csv, t.str());
  WriteTextFileAtomically(landmarks_csv, l.str());
  WriteTextFileAtomically(association_txt, a.str());
}

}  // namespace oslam
