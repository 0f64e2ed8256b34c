#include "slam/landmark_data.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include <Eigen/Cholesky>

#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/error.h"

namespace oslam {

namespace {

// A number within the physical bounds (core/bounds.h).
double Number(const std::string& path, int line, const std::string& token, const char* what,
              double bound, const char* unit) {
  const double value = ParseFiniteNumber(path, line, token, what);
  if (!bounds::Within(value, -bound, bound))
    throw Error::AtLine(
        path, line, std::string(what) + ": " + bounds::OutsideMessage(value, -bound, bound, unit));
  return value;
}

long Integer(const std::string& path, int line, const std::string& token, const char* what) {
  errno = 0;
  char* end = nullptr;
  const long value = std::strtol(token.c_str(), &end, 10);
  if (end == token.c_str() || *end != '\0' || errno == ERANGE)
    throw Error::AtLine(path, line, std::string(what) + ": '" + token + "' is not an integer");
  if (value < 0) throw Error::AtLine(path, line, std::string(what) + " must be >= 0");
  if (value > bounds::kId)
    throw Error::AtLine(
        path, line,
        std::string(what) + ": " + bounds::OutsideMessage(double(value), 0, double(bounds::kId)));
  return value;
}

// The composed odometry must stay within the coordinate bound: far beyond
// it every later number (figures, solver scaling) is meaningless.
void CheckReach(const std::string& path, const std::vector<Pose2>& poses) {
  for (size_t i = 0; i < poses.size(); ++i)
    if (!(std::abs(poses[i].x) <= bounds::kCoordinateM &&
          std::abs(poses[i].y) <= bounds::kCoordinateM))
      throw Error::InFile(
          path, bounds::ReachMessage(poses[i].x, poses[i].y, "pose " + std::to_string(i)));
}

void ExpectFields(const std::string& path, int line, const std::vector<std::string>& tokens,
                  size_t count, const std::string& layout) {
  if (tokens.size() != count)
    throw Error::AtLine(path, line,
                        "expected " + std::to_string(count) + " fields (" + layout + "), got " +
                            std::to_string(tokens.size()));
}

bool PositiveDefinite(const Eigen::Matrix3d& covariance) {
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  return llt.info() == Eigen::Success && llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0;
}

// Euler integration of the Ackermann model in the frame of the start pose,
// with first-order propagation of the input noise.
struct AckermannIntegrator {
  Eigen::Vector3d state = Eigen::Vector3d::Zero();  // (x, y, theta)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();

  void Step(double speed, double steering, double dt, const VictoriaRawOptions& o) {
    if (!(dt > 0.0)) return;
    const double t = std::tan(steering), sec2 = 1.0 + t * t;
    const double k = o.encoder_offset_m / o.wheelbase_m;
    const double denominator = 1.0 - t * k;
    // Speed of the rear-axle centre from the encoder's (rear left wheel).
    const double vc = speed / denominator;
    const double dvc_dspeed = 1.0 / denominator;
    const double dvc_dsteering = speed * k * sec2 / (denominator * denominator);
    const double c = std::cos(state.z()), s = std::sin(state.z());
    const double distance = vc * dt;
    Eigen::Matrix3d f = Eigen::Matrix3d::Identity();
    f(0, 2) = -distance * s;
    f(1, 2) = distance * c;
    // d(state)/d(vc), d(state)/d(steering) at fixed vc.
    const Eigen::Vector3d wrt_vc(dt * c, dt * s, dt * t / o.wheelbase_m);
    const Eigen::Vector3d wrt_steering_direct(0.0, 0.0, distance * sec2 / o.wheelbase_m);
    Eigen::Matrix<double, 3, 2> g;
    g.col(0) = wrt_vc * dvc_dspeed;
    g.col(1) = wrt_vc * dvc_dsteering + wrt_steering_direct;
    const double speed_std = o.speed_std_fraction * std::abs(speed) + o.speed_std_floor_mps;
    const Eigen::Vector2d input_variance(speed_std * speed_std,
                                         o.steering_std_rad * o.steering_std_rad);
    covariance = f * covariance * f.transpose() + g * input_variance.asDiagonal() * g.transpose();
    state += Eigen::Vector3d(distance * c, distance * s, distance * t / o.wheelbase_m);
  }

  RelativePoseMeasurement Finish(const VictoriaRawOptions& o) const {
    RelativePoseMeasurement m;
    m.delta = {state.x(), state.y(), WrapAngle(state.z())};
    m.covariance = covariance;
    m.covariance.diagonal() += o.increment_std_floor.cwiseAbs2();
    m.covariance = 0.5 * (m.covariance + m.covariance.transpose()).eval();
    return m;
  }
};

// Composes the odometry from pose 0 along the edges in order (each edge's
// `from` is reached before it, as the readers guarantee).
std::vector<Pose2> DeadReckoning(int num_poses, const std::vector<RelativePoseMeasurement>& edges) {
  std::vector<Pose2> poses(num_poses);
  std::vector<bool> known(num_poses, false);
  if (num_poses > 0) known[0] = true;
  for (const auto& edge : edges) {
    if (known[edge.to] || !known[edge.from]) continue;
    const Pose2& a = poses[edge.from];
    const double c = std::cos(a.theta), s = std::sin(a.theta);
    poses[edge.to] = {a.x + c * edge.delta.x - s * edge.delta.y,
                      a.y + s * edge.delta.x + c * edge.delta.y,
                      WrapAngle(a.theta + edge.delta.theta)};
    known[edge.to] = true;
  }
  return poses;
}

}  // namespace

double ParseFiniteNumber(const std::string& path, int line, const std::string& token,
                         const char* what) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0')
    throw Error::AtLine(path, line, std::string(what) + ": '" + token + "' is not a number");
  if (!std::isfinite(value) || errno == ERANGE)
    throw Error::AtLine(path, line, std::string(what) + ": '" + token + "' is not finite");
  return value;
}

void ForEachLandmarkRecord(const std::string& path,
                           const std::function<void(int, const std::vector<std::string>&)>& row) {
  std::ifstream in(path);
  if (!in) throw Error::InFile(path, "cannot open the file");
  CheckInputFile(path);
  std::string text;
  int line = 0;
  bool any = false;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    std::istringstream fields(text);
    std::vector<std::string> tokens;
    for (std::string token; fields >> token;) tokens.push_back(token);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    any = true;
    row(line, tokens);
  }
  if (in.bad()) throw Error::InFile(path, "read error");
  if (!any) throw Error::InFile(path, "no data (empty file)");
}

// ---------------------------------------------------------------------------

LandmarkDataset ReadGtsamLandmarks(const std::string& path) {
  LandmarkDataset data;
  data.path = path;
  data.format = "gtsam";
  data.has_landmark_ids = true;
  std::map<long, int> pose_index;  // file id -> index
  struct PendingSighting {
    long pose_id;
    LandmarkSighting sighting;
  };
  std::vector<PendingSighting> pending;
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    // load2D reads EDGE2 and EDGE as ODOMETRY, and VERTEX2 / VERTEX as
    // initial estimates (oslam starts from the odometry: checked, not used).
    if (t[0] == "VERTEX2" || t[0] == "VERTEX") {
      ExpectFields(path, line, t, 5, t[0] + " id x y theta");
      Integer(path, line, t[1], "pose id");
      Number(path, line, t[2], "x", bounds::kCoordinateM, "m");
      Number(path, line, t[3], "y", bounds::kCoordinateM, "m");
      Number(path, line, t[4], "theta", bounds::kAngleRad, "rad");
    } else if (t[0] == "ODOMETRY" || t[0] == "EDGE2" || t[0] == "EDGE") {
      ExpectFields(path, line, t, 12, t[0] + " i j dx dy dtheta c11 c12 c13 c22 c23 c33");
      const long i = Integer(path, line, t[1], "pose i"), j = Integer(path, line, t[2], "pose j");
      if (i == j) throw Error::AtLine(path, line, "odometry from pose " + t[1] + " to itself");
      double v[9];
      static const char* kNames[9] = {"dx",  "dy",  "dtheta", "c11", "c12",
                                      "c13", "c22", "c23",    "c33"};
      for (int k = 0; k < 9; ++k)
        v[k] = k < 2    ? Number(path, line, t[3 + k], kNames[k], bounds::kCoordinateM, "m")
               : k == 2 ? Number(path, line, t[3 + k], kNames[k], bounds::kAngleRad, "rad")
                        : ParseFiniteNumber(path, line, t[3 + k], kNames[k]);
      RelativePoseMeasurement edge;
      edge.delta = {v[0], v[1], v[2]};
      // load2D's automatic noise format: a diagonal at entries 1, 3, 4 is a
      // covariance in TORO's order (ff fs ss rr fr sr); anything else is
      // the upper triangle, row-major.
      const bool graph_order =
          v[4] == 0 && v[7] == 0 && v[8] == 0 && v[3] != 0 && v[5] != 0 && v[6] != 0;
      if (graph_order)
        edge.covariance << v[3], v[4], v[7], v[4], v[5], v[8], v[7], v[8], v[6];
      else
        edge.covariance << v[3], v[4], v[5], v[4], v[6], v[7], v[5], v[7], v[8];
      if (!PositiveDefinite(edge.covariance))
        throw Error::AtLine(path, line, "the odometry covariance is not positive definite");
      if (pose_index.empty()) {
        pose_index[i] = 0;
        data.pose_ids.push_back(i);
      }
      const auto from = pose_index.find(i);
      if (from == pose_index.end())
        throw Error::AtLine(
            path, line,
            "odometry starts at pose " + t[1] + ", which no earlier odometry line reaches");
      edge.from = from->second;
      const auto to = pose_index.find(j);
      if (to == pose_index.end()) {
        edge.to = static_cast<int>(data.pose_ids.size());
        pose_index[j] = edge.to;
        data.pose_ids.push_back(j);
      } else {
        edge.to = to->second;  // loop closure
      }
      data.odometry.push_back(edge);
    } else if (t[0] == "LANDMARK") {
      ExpectFields(path, line, t, 8, "LANDMARK i l x y c11 c12 c22");
      PendingSighting p;
      p.pose_id = Integer(path, line, t[1], "pose i");
      LandmarkSighting& s = p.sighting;
      s.line = line;
      const long id = Integer(path, line, t[2], "landmark l");
      if (id > std::numeric_limits<int>::max())
        throw Error::AtLine(path, line, "landmark id " + t[2] + " is too large");
      s.landmark = static_cast<int>(id);
      const double x = Number(path, line, t[3], "x", bounds::kCoordinateM, "m"),
                   y = Number(path, line, t[4], "y", bounds::kCoordinateM, "m");
      const double c11 = ParseFiniteNumber(path, line, t[5], "c11"),
                   c12 = ParseFiniteNumber(path, line, t[6], "c12"),
                   c22 = ParseFiniteNumber(path, line, t[7], "c22");
      if (!(c11 > 0 && c22 > 0 && c11 * c22 - c12 * c12 > 0))
        throw Error::AtLine(path, line, "the landmark covariance is not positive definite");
      s.range_m = std::hypot(x, y);
      if (!(s.range_m > 0)) throw Error::AtLine(path, line, "landmark at range 0 (no bearing)");
      s.bearing_rad = std::atan2(y, x);
      if (std::abs(c11 - c22) < 1e-4) {
        // GTSAM's load2D: the covariance read as the uncertainty at 10 m.
        s.bearing_std_rad = std::sqrt(c11 / 10.0);
        s.range_std_m = std::sqrt(c11);
      } else {
        // load2D would use 1 and 1; the point with its own covariance is
        // what the line says.
        s.cartesian = true;
        s.xy_covariance << c11, c12, c12, c22;
        const Eigen::Vector2d radial(x / s.range_m, y / s.range_m);
        const Eigen::Vector2d tangential(-radial.y(), radial.x());
        s.range_std_m = std::sqrt(radial.dot(s.xy_covariance * radial));
        s.bearing_std_rad = std::sqrt(tangential.dot(s.xy_covariance * tangential)) / s.range_m;
      }
      pending.push_back(p);
    } else if (t[0] == "BR") {
      ExpectFields(path, line, t, 7, "BR i l bearing range bearing_std range_std");
      PendingSighting p;
      p.pose_id = Integer(path, line, t[1], "pose i");
      LandmarkSighting& s = p.sighting;
      s.line = line;
      const long id = Integer(path, line, t[2], "landmark l");
      if (id > std::numeric_limits<int>::max())
        throw Error::AtLine(path, line, "landmark id " + t[2] + " is too large");
      s.landmark = static_cast<int>(id);
      s.bearing_rad = ParseFiniteNumber(path, line, t[3], "bearing");
      s.range_m = ParseFiniteNumber(path, line, t[4], "range");
      s.bearing_std_rad = ParseFiniteNumber(path, line, t[5], "bearing_std");
      s.range_std_m = ParseFiniteNumber(path, line, t[6], "range_std");
      if (!(s.range_m > 0)) throw Error::AtLine(path, line, "range must be > 0");
      if (!(s.bearing_std_rad > 0) || !(s.range_std_m > 0))
        throw Error::AtLine(path, line, "the noise stds must be > 0");
      pending.push_back(p);
    } else {
      throw Error::AtLine(
          path, line,
          "unknown record '" + t[0] + "' (expected ODOMETRY, EDGE2, LANDMARK, BR or VERTEX2)");
    }
  });
  if (data.pose_ids.empty()) throw Error::InFile(path, "no ODOMETRY (or EDGE2) lines");
  for (auto& p : pending) {
    const auto found = pose_index.find(p.pose_id);
    if (found == pose_index.end())
      throw Error::AtLine(path, p.sighting.line,
                          "landmark seen from pose " + std::to_string(p.pose_id) +
                              ", which no odometry line reaches");
    p.sighting.pose = found->second;
    data.sightings.push_back(p.sighting);
  }
  data.num_poses = static_cast<int>(data.pose_ids.size());
  data.dead_reckoning = DeadReckoning(data.num_poses, data.odometry);
  CheckReach(path, data.dead_reckoning);
  return data;
}

// ---------------------------------------------------------------------------

bool VictoriaRawOptions::Validate(std::string* why) const {
  auto fail = [&](const char* message) {
    if (why) *why = message;
    return false;
  };
  if (!(wheelbase_m > 0) || !std::isfinite(wheelbase_m)) return fail("wheelbase must be > 0");
  if (!std::isfinite(encoder_offset_m)) return fail("encoder offset must be finite");
  if (!laser_offset_m.allFinite()) return fail("laser offset must be finite");
  if (!(speed_std_fraction >= 0) || !(speed_std_floor_mps >= 0) || !(steering_std_rad >= 0))
    return fail("input noise must be >= 0");
  if (!(increment_std_floor.minCoeff() > 0) || !increment_std_floor.allFinite())
    return fail("the increment noise floor must be > 0 and finite");
  if (!(range_std_m > 0) || !(bearing_std_rad > 0) || !std::isfinite(range_std_m) ||
      !std::isfinite(bearing_std_rad))
    return fail("laser noise must be > 0 and finite");
  if (!(min_range_m >= 0) || !(max_range_m > min_range_m))
    return fail("need 0 <= min range < max range");
  return true;
}

RelativePoseMeasurement IntegrateAckermann(double speed_mps, double steering_rad, double dt_s,
                                           const VictoriaRawOptions& options, int steps) {
  AckermannIntegrator integrator;
  for (int k = 0; k < steps; ++k) integrator.Step(speed_mps, steering_rad, dt_s / steps, options);
  RelativePoseMeasurement m = integrator.Finish(options);
  m.from = 0;
  m.to = 1;
  return m;
}

LandmarkDataset ReadVictoriaRaw(const std::string& measurements_path,
                                const std::string& inputs_path, const VictoriaRawOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("Victoria Park raw options: " + why);
  LandmarkDataset data;
  data.path = measurements_path;
  data.format = "victoria-raw";
  data.sensor_offset_m = options.laser_offset_m;

  // Scans: one pose per distinct time.
  double last_time = -std::numeric_limits<double>::infinity();
  ForEachLandmarkRecord(measurements_path, [&](int line, const std::vector<std::string>& t) {
    ExpectFields(measurements_path, line, t, 4, "time range bearing diameter");
    const double time = ParseFiniteNumber(measurements_path, line, t[0], "time");
    const double range = Number(measurements_path, line, t[1], "range", bounds::kCoordinateM, "m");
    const double bearing =
        Number(measurements_path, line, t[2], "bearing", bounds::kAngleRad, "rad");
    const double diameter =
        Number(measurements_path, line, t[3], "diameter", bounds::kObjectSizeM, "m");
    if (time < last_time)
      throw Error::AtLine(measurements_path, line, "time goes backwards (" + t[0] + " s)");
    if (range < 0) throw Error::AtLine(measurements_path, line, "negative range");
    if (diameter < 0) throw Error::AtLine(measurements_path, line, "negative diameter");
    if (time > last_time) {
      data.pose_times.push_back(time);
      data.pose_ids.push_back(static_cast<long>(data.pose_times.size()) - 1);
      last_time = time;
    }
    if (range < options.min_range_m || range > options.max_range_m) return;
    LandmarkSighting s;
    s.pose = static_cast<int>(data.pose_times.size()) - 1;
    s.range_m = range;
    s.bearing_rad = WrapAngle(bearing - kPi / 2);  // laser: pi/2 = ahead
    s.range_std_m = options.range_std_m;
    s.bearing_std_rad = options.bearing_std_rad;
    s.diameter_m = diameter;
    s.line = line;
    data.sightings.push_back(s);
  });
  data.num_poses = static_cast<int>(data.pose_times.size());

  // Inputs: piecewise constant from each sample's time to the next one's.
  struct Input {
    double time, speed, steering;
  };
  std::vector<Input> inputs;
  ForEachLandmarkRecord(inputs_path, [&](int line, const std::vector<std::string>& t) {
    ExpectFields(inputs_path, line, t, 3, "time speed steering");
    const Input input{ParseFiniteNumber(inputs_path, line, t[0], "time"),
                      Number(inputs_path, line, t[1], "speed", bounds::kSpeedMps, "m/s"),
                      ParseFiniteNumber(inputs_path, line, t[2], "steering")};
    if (!inputs.empty() && input.time < inputs.back().time)
      throw Error::AtLine(inputs_path, line, "time goes backwards (" + t[0] + " s)");
    if (std::abs(input.steering) >= kPi / 2)
      throw Error::AtLine(inputs_path, line, "steering angle beyond +-pi/2");
    if (std::abs(std::tan(input.steering)) * options.encoder_offset_m / options.wheelbase_m >= 1)
      throw Error::AtLine(inputs_path, line, "steering too sharp for the Ackermann geometry");
    inputs.push_back(input);
  });
  if (data.num_poses > 1 && inputs.front().time > data.pose_times[1])
    throw Error::InFile(inputs_path, "the inputs start after the second laser scan (" +
                                         std::to_string(data.pose_times[1]) + " s)");

  // Integrate between consecutive scans. Before the first input sample the
  // vehicle is taken to stand still; after the last one it keeps that input.
  size_t k = 0;
  for (int i = 1; i < data.num_poses; ++i) {
    const double start = data.pose_times[i - 1], end = data.pose_times[i];
    AckermannIntegrator integrator;
    while (k + 1 < inputs.size() && inputs[k + 1].time <= start) ++k;
    for (size_t m = k; m < inputs.size(); ++m) {
      const double from = std::max(start, inputs[m].time);
      const double to = m + 1 < inputs.size() ? std::min(end, inputs[m + 1].time) : end;
      if (inputs[m].time >= end) break;
      if (to > from) integrator.Step(inputs[m].speed, inputs[m].steering, to - from, options);
    }
    RelativePoseMeasurement edge = integrator.Finish(options);
    edge.from = i - 1;
    edge.to = i;
    data.odometry.push_back(edge);
  }
  data.dead_reckoning = DeadReckoning(data.num_poses, data.odometry);
  CheckReach(inputs_path, data.dead_reckoning);
  return data;
}

// ---------------------------------------------------------------------------

std::vector<GpsFix> ReadGps(const std::string& path) {
  std::vector<GpsFix> fixes;
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    ExpectFields(path, line, t, 3, "time x y");
    GpsFix fix{ParseFiniteNumber(path, line, t[0], "time"),
               Number(path, line, t[1], "x", bounds::kCoordinateM, "m"),
               Number(path, line, t[2], "y", bounds::kCoordinateM, "m")};
    if (!fixes.empty() && fix.time_s < fixes.back().time_s)
      throw Error::AtLine(path, line, "time goes backwards (" + t[0] + " s)");
    fixes.push_back(fix);
  });
  return fixes;
}

bool GpsComparisonOptions::Validate(std::string* why) const {
  if (!(max_gap_s > 0)) {
    *why = "max_gap_s must be positive";
    return false;
  }
  if (!antenna_offset_m.allFinite()) {
    *why = "antenna_offset_m must be finite";
    return false;
  }
  return true;
}

namespace {

// A pose interpolated at a fix's time, and the fix.
struct GpsPair {
  Eigen::Vector2d position_m, fix_m;
  double heading_rad = 0;
};

std::vector<GpsPair> PairWithFixes(const std::vector<Pose2>& trajectory,
                                   const std::vector<double>& times_s,
                                   const std::vector<GpsFix>& gps, double max_gap_s) {
  std::vector<GpsPair> pairs;
  size_t i = 0;
  for (const GpsFix& fix : gps) {
    while (i + 2 < times_s.size() && times_s[i + 1] <= fix.time_s) ++i;
    if (times_s.size() < 2 || fix.time_s < times_s[i] || fix.time_s > times_s[i + 1]) continue;
    const double gap = times_s[i + 1] - times_s[i];
    if (!(gap > 0) || gap > max_gap_s) continue;
    const double w = (fix.time_s - times_s[i]) / gap;
    const Pose2& a = trajectory[i];
    const Pose2& b = trajectory[i + 1];
    pairs.push_back({{(1 - w) * a.x + w * b.x, (1 - w) * a.y + w * b.y},
                     {fix.x_m, fix.y_m},
                     a.theta + w * WrapAngle(b.theta - a.theta)});
  }
  return pairs;
}

Eigen::Matrix2d Rotation2(double angle_rad) {
  const double c = std::cos(angle_rad), s = std::sin(angle_rad);
  return (Eigen::Matrix2d() << c, -s, s, c).finished();
}

Eigen::Vector2d AntennaOf(const GpsPair& pair, const Eigen::Vector2d& offset_m) {
  return pair.position_m + Rotation2(pair.heading_rad) * offset_m;
}

// Planar Procrustes of the antenna positions onto the fixes.
void AlignRigidly(const std::vector<GpsPair>& pairs, GpsError* result) {
  const double n = static_cast<double>(pairs.size());
  Eigen::Vector2d mean_e = Eigen::Vector2d::Zero(), mean_m = Eigen::Vector2d::Zero();
  for (const GpsPair& p : pairs) {
    mean_e += AntennaOf(p, result->antenna_offset_m);
    mean_m += p.fix_m;
  }
  mean_e /= n;
  mean_m /= n;
  double dot = 0, cross = 0;  // the angle maximising sum m_k . R e_k
  for (const GpsPair& p : pairs) {
    const Eigen::Vector2d e = AntennaOf(p, result->antenna_offset_m) - mean_e, m = p.fix_m - mean_m;
    dot += e.dot(m);
    cross += e.x() * m.y() - e.y() * m.x();
  }
  result->rotation_rad = std::atan2(cross, dot);
  result->translation_m = mean_m - Rotation2(result->rotation_rad) * mean_e;
}

// The offset minimising the misfit for the alignment held: R R(theta_k) is a
// rotation, so the normal equations are n I and the offset a mean.
Eigen::Vector2d BestAntennaOffset(const std::vector<GpsPair>& pairs, const GpsError& alignment) {
  const Eigen::Matrix2d rotation = Rotation2(alignment.rotation_rad);
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const GpsPair& p : pairs) {
    const Eigen::Vector2d misfit = p.fix_m - (rotation * p.position_m + alignment.translation_m);
    sum += Rotation2(alignment.rotation_rad + p.heading_rad).transpose() * misfit;
  }
  return sum / static_cast<double>(pairs.size());
}

}  // namespace

GpsError CompareWithGps(const std::vector<Pose2>& trajectory, const std::vector<double>& times_s,
                        const std::vector<GpsFix>& gps, const GpsComparisonOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("GPS comparison options: " + why);
  if (trajectory.size() != times_s.size())
    throw Error("GPS comparison: " + std::to_string(trajectory.size()) + " poses but " +
                std::to_string(times_s.size()) + " times");
  for (size_t i = 1; i < times_s.size(); ++i)
    if (times_s[i] < times_s[i - 1]) throw Error("GPS comparison: pose times decrease");
  const std::vector<GpsPair> pairs = PairWithFixes(trajectory, times_s, gps, options.max_gap_s);
  const size_t min_fixes = options.estimate_antenna_offset ? 3 : 2;
  if (pairs.size() < min_fixes)
    throw Error("GPS comparison: fewer than " + std::to_string(min_fixes) +
                " fixes fall within the trajectory's times");
  GpsError result;
  result.antenna_offset_m =
      options.estimate_antenna_offset ? Eigen::Vector2d::Zero() : options.antenna_offset_m;
  AlignRigidly(pairs, &result);
  // Block coordinate descent on (alignment, offset): each block's exact
  // minimum; with headings that vary along the drive it converges in a few
  // rounds.
  for (int round = 0; options.estimate_antenna_offset && round < 200; ++round) {
    const Eigen::Vector2d offset = BestAntennaOffset(pairs, result);
    const double change = (offset - result.antenna_offset_m).norm();
    result.antenna_offset_m = offset;
    AlignRigidly(pairs, &result);
    if (change < 1e-9) break;
  }
  const Eigen::Matrix2d rotation = Rotation2(result.rotation_rad);
  const size_t n = pairs.size();
  std::vector<double> errors(n);
  double sum_sq = 0;
  for (size_t k = 0; k < n; ++k) {
    errors[k] = (rotation * AntennaOf(pairs[k], result.antenna_offset_m) + result.translation_m -
                 pairs[k].fix_m)
                    .norm();
    sum_sq += errors[k] * errors[k];
  }
  std::sort(errors.begin(), errors.end());
  result.num_fixes = static_cast<int>(n);
  result.rmse_m = std::sqrt(sum_sq / n);
  result.median_m = errors[n / 2];
  result.p95_m = errors[std::min(n - 1, n * 95 / 100)];
  result.max_m = errors.back();
  return result;
}

std::vector<int> GivenAssociation(const LandmarkDataset& data) {
  std::vector<int> association;
  association.reserve(data.sightings.size());
  for (const auto& s : data.sightings) association.push_back(s.landmark);
  return association;
}

std::vector<int> ReadAssociation(const std::string& path, size_t num_sightings) {
  std::vector<int> association;
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    ExpectFields(path, line, t, 1, "landmark id");
    errno = 0;
    char* end = nullptr;
    const long id = std::strtol(t[0].c_str(), &end, 10);
    if (end == t[0].c_str() || *end != '\0' || errno == ERANGE || id < -1 ||
        id > std::numeric_limits<int>::max())
      throw Error::AtLine(path, line, "'" + t[0] + "' is not a landmark id (integer >= -1)");
    association.push_back(static_cast<int>(id));
  });
  if (association.size() != num_sightings)
    throw Error::InFile(path, std::to_string(association.size()) + " ids for " +
                                  std::to_string(num_sightings) + " sightings");
  return association;
}

std::optional<double> MeanMeasuredDiameter(const std::vector<LandmarkSighting>& sightings,
                                           const std::vector<int>& indices) {
  double sum = 0;
  int count = 0;
  for (int k : indices)
    if (std::isfinite(sightings[k].diameter_m)) {
      sum += sightings[k].diameter_m;
      ++count;
    }
  if (count == 0) return std::nullopt;
  return sum / count;
}

}  // namespace oslam
