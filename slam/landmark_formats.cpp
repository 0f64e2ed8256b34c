#include "slam/landmark_formats.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include <Eigen/Cholesky>

#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/bounds.h"
#include "core/error.h"
#include "slam/landmark_data.h"
#include "slam/landmark_factors.h"

namespace oslam {
namespace {

// ---- tokens ----

struct Record {
  const std::string& path;
  int line;
  const std::vector<std::string>& tokens;

  void Expect(size_t count, const char* layout) const {
    if (tokens.size() != count)
      throw Error::AtLine(path, line,
                          tokens[0] + ": expected " + std::to_string(count - 1) + " fields (" +
                              layout + "), got " + std::to_string(tokens.size() - 1));
  }
  double Number(size_t i, const char* what) const {
    return ParseFiniteNumber(path, line, tokens[i], what);
  }
  // A number within +-bound (docs/formats.md, Bounds): a finite but absurd
  // value (a vertex at 1e300 m) would leave every later step meaningless.
  double Bounded(size_t i, const char* what, double bound, const char* unit) const {
    const double value = Number(i, what);
    if (!bounds::Within(value, -bound, bound))
      Fail(std::string(what) + ": " + bounds::OutsideMessage(value, -bound, bound, unit));
    return value;
  }
  double Coordinate(size_t i, const char* what) const {
    return Bounded(i, what, bounds::kCoordinateM, "m");
  }
  double Angle(size_t i, const char* what) const {
    return Bounded(i, what, bounds::kAngleRad, "rad");
  }
  // A vertex's estimate (x y theta from token i on, or x y).
  void Estimate(size_t i, bool with_angle) const {
    Coordinate(i, "x");
    Coordinate(i + 1, "y");
    if (with_angle) Angle(i + 2, "theta");
  }
  // A relative pose (dx dy dtheta from token i on).
  Pose2 Delta(size_t i, const char* x, const char* y, const char* theta) const {
    return {Coordinate(i, x), Coordinate(i + 1, y), Angle(i + 2, theta)};
  }
  long Id(size_t i, const char* what) const {
    const std::string& token = tokens[i];
    errno = 0;
    char* end = nullptr;
    const long value = std::strtol(token.c_str(), &end, 10);
    if (end == token.c_str() || *end != '\0' || errno == ERANGE)
      throw Error::AtLine(path, line, std::string(what) + ": '" + token + "' is not an integer");
    if (value < 0 || value > bounds::kId)
      Fail(std::string(what) + " " + bounds::OutsideMessage(double(value), 0, double(bounds::kId)));
    return value;
  }
  [[noreturn]] void Fail(const std::string& what) const { throw Error::AtLine(path, line, what); }
};

// ---- noise ----

Eigen::Matrix3d Symmetric3(double a11, double a12, double a13, double a22, double a23, double a33) {
  Eigen::Matrix3d m;
  m << a11, a12, a13, a12, a22, a23, a13, a23, a33;
  return m;
}

bool PositiveDefinite(const Eigen::MatrixXd& m) {
  const Eigen::LLT<Eigen::MatrixXd> llt(m);
  return llt.info() == Eigen::Success && llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0;
}

// The covariance of an information matrix (checked positive definite).
template <int N>
Eigen::Matrix<double, N, N> CovarianceOfInformation(const Eigen::Matrix<double, N, N>& information,
                                                    const Record& r) {
  if (!PositiveDefinite(information)) r.Fail("the information matrix is not positive definite");
  Eigen::Matrix<double, N, N> c = information.llt().solve(Eigen::Matrix<double, N, N>::Identity());
  return 0.5 * (c + c.transpose());
}

// The covariance of an upper-triangular square-root information R (R^T R
// the information), its diagonal checked non-zero.
template <int N>
Eigen::Matrix<double, N, N> CovarianceOfSqrtInformation(const Eigen::Matrix<double, N, N>& r_upper,
                                                        const Record& r) {
  for (int i = 0; i < N; ++i)
    if (!(std::abs(r_upper(i, i)) > 0))
      r.Fail("the square-root information matrix has a zero on its diagonal");
  const Eigen::Matrix<double, N, N> inverse = r_upper.template triangularView<Eigen::Upper>().solve(
      Eigen::Matrix<double, N, N>::Identity());
  Eigen::Matrix<double, N, N> c = inverse * inverse.transpose();
  return 0.5 * (c + c.transpose());
}

// ---- building a data set from file ids ----

struct PendingEdge {
  long from, to;
  Pose2 delta;
  Eigen::Matrix3d covariance;
  int line;
};
struct PendingSighting {
  long pose, landmark;
  Eigen::Vector2d point;
  Eigen::Matrix2d covariance;
  int line;
};

// Collects a file's poses, odometry and point sightings by their file ids;
// Finish() numbers the poses and checks that the odometry reaches them.
class Builder {
 public:
  Builder(std::string path, std::string format, bool poses_by_id)
      : path_(std::move(path)), format_(std::move(format)), poses_by_id_(poses_by_id) {}

  void DeclarePose(long id, const Record& r) {
    if (landmarks_.count(id)) r.Fail("vertex " + std::to_string(id) + " is already a landmark");
    if (!declared_poses_.insert(id).second)
      r.Fail("pose " + std::to_string(id) + " is declared twice");
    NotePose(id);
  }
  void DeclareLandmark(long id, const Record& r) {
    if (declared_poses_.count(id)) r.Fail("vertex " + std::to_string(id) + " is already a pose");
    if (!landmarks_.insert(id).second)
      r.Fail("landmark " + std::to_string(id) + " is declared twice");
    declared_landmarks_ = true;
  }
  void AddEdge(long from, long to, const Pose2& delta, const Eigen::Matrix3d& covariance,
               const Record& r) {
    if (from == to) r.Fail("odometry from pose " + std::to_string(from) + " to itself");
    for (long id : {from, to}) CheckPose(id, r);
    edges_.push_back({from, to, delta, covariance, r.line});
  }
  void AddSighting(long pose, long landmark, const Eigen::Vector2d& point,
                   const Eigen::Matrix2d& covariance, const Record& r) {
    CheckPose(pose, r);
    if (declared_poses_.count(landmark))
      r.Fail("landmark " + std::to_string(landmark) + " is a pose vertex");
    if (declared_landmarks_ && !landmarks_.count(landmark))
      r.Fail("landmark " + std::to_string(landmark) + " has no vertex");
    if (!(point.norm() > 0)) r.Fail("landmark at range 0 (no bearing)");
    if (!PositiveDefinite(covariance)) r.Fail("the landmark noise is not positive definite");
    sightings_.push_back({pose, landmark, point, covariance, r.line});
  }
  // No vertex lines: every id on an edge is a pose.
  void SetPosesDeclared(bool declared) { poses_declared_ = declared; }

  LandmarkDataset Finish();

 private:
  void NotePose(long id) {
    if (index_.emplace(id, static_cast<int>(order_.size())).second) order_.push_back(id);
  }
  void CheckPose(long id, const Record& r) {
    if (poses_declared_ && !declared_poses_.count(id))
      r.Fail("pose " + std::to_string(id) + " has no vertex");
    if (landmarks_.count(id)) r.Fail("vertex " + std::to_string(id) + " is a landmark, not a pose");
    NotePose(id);
  }

  std::string path_, format_;
  bool poses_by_id_;             // number poses by ascending id (else first mention)
  bool poses_declared_ = false;  // ids must have a vertex line
  bool declared_landmarks_ = false;
  std::set<long> declared_poses_, landmarks_;
  std::map<long, int> index_;  // first-mention order
  std::vector<long> order_;
  std::vector<PendingEdge> edges_;
  std::vector<PendingSighting> sightings_;
};

Pose2 InversePose(const Pose2& z) {
  return BetweenPoses(z, Pose2{});
}

LandmarkDataset Builder::Finish() {
  LandmarkDataset data;
  data.path = path_;
  data.format = format_;
  std::vector<long> ids = order_;
  if (poses_by_id_) std::sort(ids.begin(), ids.end());
  if (ids.empty()) throw Error::InFile(path_, "no poses");
  std::map<long, int> index;
  for (size_t i = 0; i < ids.size(); ++i) index[ids[i]] = static_cast<int>(i);
  data.num_poses = static_cast<int>(ids.size());
  data.pose_ids = ids;
  for (const PendingEdge& e : edges_) {
    RelativePoseMeasurement m;
    m.from = index.at(e.from);
    m.to = index.at(e.to);
    m.delta = e.delta;
    m.covariance = e.covariance;
    data.odometry.push_back(m);
  }
  // Dead reckoning: each pose from an edge to an earlier one (the nearest
  // earlier pose when several), so every prefix of the poses is connected.
  std::vector<int> parent_edge(data.num_poses, -1), parent(data.num_poses, -1);
  for (size_t k = 0; k < data.odometry.size(); ++k) {
    const RelativePoseMeasurement& e = data.odometry[k];
    const int later = std::max(e.from, e.to), earlier = std::min(e.from, e.to);
    if (earlier > parent[later]) {
      parent[later] = earlier;
      parent_edge[later] = static_cast<int>(k);
    }
  }
  data.dead_reckoning.assign(data.num_poses, Pose2{});
  for (int i = 1; i < data.num_poses; ++i) {
    if (parent_edge[i] < 0)
      throw Error::InFile(path_, "pose " + std::to_string(ids[i]) +
                                     " has no odometry edge to an earlier pose (poses are "
                                     "numbered by " +
                                     (poses_by_id_ ? "id" : "first mention") + ")");
    const RelativePoseMeasurement& e = data.odometry[parent_edge[i]];
    const Pose2& p = data.dead_reckoning[i] =
        e.to == i ? ComposePose(data.dead_reckoning[parent[i]], e.delta)
                  : ComposePose(data.dead_reckoning[parent[i]], InversePose(e.delta));
    // Each increment is bounded, their sum is not: the composed odometry
    // must stay within the position bound too (as the GTSAM reader's).
    if (!(std::abs(p.x) <= bounds::kCoordinateM && std::abs(p.y) <= bounds::kCoordinateM))
      throw Error::InFile(path_, bounds::ReachMessage(p.x, p.y, "pose " + std::to_string(ids[i])));
  }
  for (const PendingSighting& p : sightings_) {
    LandmarkSighting s;
    s.pose = index.at(p.pose);
    s.landmark = static_cast<int>(p.landmark);
    s.cartesian = true;
    s.range_m = p.point.norm();
    s.bearing_rad = std::atan2(p.point.y(), p.point.x());
    s.xy_covariance = p.covariance;
    // The stds of the equivalent range-bearing noise (for messages only).
    const Eigen::Vector2d radial = p.point / s.range_m, tangential(-radial.y(), radial.x());
    s.range_std_m = std::sqrt(radial.dot(p.covariance * radial));
    s.bearing_std_rad = std::sqrt(tangential.dot(p.covariance * tangential)) / s.range_m;
    s.line = p.line;
    data.sightings.push_back(s);
  }
  data.has_landmark_ids = true;  // the file's landmark vertices
  return data;
}

bool IsG2oTag(const std::string& tag) {
  return tag == "VERTEX_SE2" || tag == "VERTEX_XY" || tag == "EDGE_SE2" || tag == "EDGE_SE2_XY" ||
         tag == "FIX";
}

}  // namespace

// ---------------------------------------------------------------------------

const char* LandmarkFormatName(LandmarkFormat format) {
  switch (format) {
    case LandmarkFormat::kGtsam:
      return "gtsam";
    case LandmarkFormat::kG2o:
      return "g2o";
    case LandmarkFormat::kToro:
      return "toro";
    case LandmarkFormat::kIsam:
      return "isam";
    case LandmarkFormat::kVictoriaRaw:
      return "victoria-raw";
  }
  return "?";
}

std::optional<LandmarkFormat> LandmarkFormatFromName(const std::string& name) {
  for (LandmarkFormat f : {LandmarkFormat::kGtsam, LandmarkFormat::kG2o, LandmarkFormat::kToro,
                           LandmarkFormat::kIsam, LandmarkFormat::kVictoriaRaw})
    if (name == LandmarkFormatName(f)) return f;
  return std::nullopt;
}

DetectedLandmarkFormat DetectLandmarkFormat(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    if (fs::exists(fs::path(path) / "measurements.dat", ec))
      return {LandmarkFormat::kVictoriaRaw, "a folder with measurements.dat"};
    throw Error::InFile(path, "a folder without measurements.dat: no landmark data set");
  }
  if (fs::path(path).filename() == "measurements.dat")
    return {LandmarkFormat::kVictoriaRaw, "named measurements.dat"};
  bool g2o = false, vertex2 = false, edge2 = false, landmark = false, odometry = false;
  bool bearing_range = false, equiv = false;
  bool toro_diagonal = true, isam_diagonal = true;
  int first_unknown = 0;
  std::string unknown;
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    const std::string& tag = t[0];
    if (IsG2oTag(tag)) {
      g2o = true;
    } else if (tag == "VERTEX2") {
      vertex2 = true;
    } else if (tag == "EDGE2") {
      edge2 = true;
      // Noise entries 1..6: TORO writes a diagonal information at 1, 3, 4
      // (ff, ss, rr), iSAM a diagonal square-root information at 1, 4, 6.
      auto zero = [&](size_t i) {
        return t.size() > 5 + i && std::strtod(t[5 + i].c_str(), nullptr) == 0.0;
      };
      auto nonzero = [&](size_t i) { return t.size() > 5 + i && !zero(i); };
      if (t.size() != 12 ||
          !(zero(2) && zero(5) && zero(6) && nonzero(1) && nonzero(3) && nonzero(4)))
        toro_diagonal = false;
      if (t.size() != 12 ||
          !(zero(2) && zero(3) && zero(5) && nonzero(1) && nonzero(4) && nonzero(6)))
        isam_diagonal = false;
    } else if (tag == "LANDMARK") {
      landmark = true;
    } else if (tag == "ODOMETRY" || tag == "BR") {
      odometry = true;
      bearing_range = bearing_range || tag == "BR";
    } else if (tag == "EQUIV") {
      equiv = true;
    } else if (first_unknown == 0) {
      first_unknown = line;
      unknown = tag;
    }
  });
  if (g2o) return {LandmarkFormat::kG2o, "g2o records (VERTEX_SE2, EDGE_SE2, ...)"};
  // BR is load2D's alone; load2D also reads VERTEX2 and EDGE2 (as
  // covariances), TORO neither BR nor covariances.
  if (bearing_range && (vertex2 || edge2) && !equiv)
    return {LandmarkFormat::kGtsam, "BR records with VERTEX2/EDGE2 (GTSAM's load2D)"};
  if (vertex2 || equiv) return {LandmarkFormat::kToro, "TORO's VERTEX2 or EQUIV records"};
  if (edge2 && landmark) return {LandmarkFormat::kIsam, "EDGE2 with LANDMARK records (iSAM)"};
  if (edge2 && !odometry) {
    if (toro_diagonal && !isam_diagonal)
      return {LandmarkFormat::kToro, "EDGE2 noise diagonal in TORO's order (ff fs ss rr fr sr)"};
    if (isam_diagonal && !toro_diagonal)
      return {LandmarkFormat::kIsam, "EDGE2 noise diagonal in iSAM's order (xx xy xt yy yt tt)"};
    throw Error::InFile(path,
                        "EDGE2 records are TORO's (information) or iSAM's (square-root "
                        "information) and their noise does not tell which: give the format");
  }
  if (odometry || landmark)
    return {LandmarkFormat::kGtsam,
            "ODOMETRY/LANDMARK records read as GTSAM's load2D (covariances; iSAM writes the "
            "same records with square-root information: give format isam for those)"};
  throw Error::AtLine(path, first_unknown,
                      "unknown record '" + unknown + "': no landmark format recognised");
}

// ---------------------------------------------------------------------------

LandmarkDataset ReadG2oLandmarks(const std::string& path) {
  Builder builder(path, "g2o", /*poses_by_id=*/true);
  // Vertices first (g2o declares them before use, but a file may not).
  bool any_vertex = false;
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    const Record r{path, line, t};
    if (t[0] == "VERTEX_SE2") {
      r.Expect(5, "id x y theta");
      r.Estimate(2, /*with_angle=*/true);
      builder.DeclarePose(r.Id(1, "pose id"), r);
      any_vertex = true;
    } else if (t[0] == "VERTEX_XY") {
      r.Expect(4, "id x y");
      r.Estimate(2, /*with_angle=*/false);
      builder.DeclareLandmark(r.Id(1, "landmark id"), r);
    } else if (!IsG2oTag(t[0])) {
      r.Fail("unknown record '" + t[0] +
             "' (g2o 2D: VERTEX_SE2, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY, FIX)");
    }
  });
  builder.SetPosesDeclared(any_vertex);
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    const Record r{path, line, t};
    if (t[0] == "EDGE_SE2") {
      r.Expect(12, "i j dx dy dtheta i11 i12 i13 i22 i23 i33");
      const Pose2 delta = r.Delta(3, "dx", "dy", "dtheta");
      double v[6];
      for (int k = 0; k < 6; ++k) v[k] = r.Number(6 + k, "information");
      const Eigen::Matrix3d information = Symmetric3(v[0], v[1], v[2], v[3], v[4], v[5]);
      builder.AddEdge(r.Id(1, "pose i"), r.Id(2, "pose j"), delta,
                      CovarianceOfInformation<3>(information, r), r);
    } else if (t[0] == "EDGE_SE2_XY") {
      r.Expect(8, "i j x y i11 i12 i22");
      Eigen::Matrix2d information;
      information << r.Number(5, "i11"), r.Number(6, "i12"), r.Number(6, "i12"), r.Number(7, "i22");
      builder.AddSighting(r.Id(1, "pose i"), r.Id(2, "landmark j"),
                          Eigen::Vector2d(r.Coordinate(3, "x"), r.Coordinate(4, "y")),
                          CovarianceOfInformation<2>(information, r), r);
    } else if (t[0] == "FIX") {
      // The gauge: oslam holds the first pose (the lowest id) instead.
      if (t.size() < 2) r.Fail("FIX: expected a vertex id");
      for (size_t i = 1; i < t.size(); ++i) r.Id(i, "vertex id");
    }
  });
  return builder.Finish();
}

LandmarkDataset ReadToroGraph(const std::string& path) {
  Builder builder(path, "toro", /*poses_by_id=*/true);
  bool any_vertex = false;
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    const Record r{path, line, t};
    if (t[0] == "VERTEX2") {
      r.Expect(5, "id x y theta");
      r.Estimate(2, /*with_angle=*/true);
      builder.DeclarePose(r.Id(1, "pose id"), r);
      any_vertex = true;
    } else if (t[0] == "EQUIV") {
      // TORO collapses the edge between two equivalent nodes into one node;
      // oslam keeps both poses and the edge with its own noise (as GTSAM's
      // load2D, which skips EQUIV). Checked, otherwise not used.
      r.Expect(3, "id1 id2");
      r.Id(1, "pose id1");
      r.Id(2, "pose id2");
    } else if (t[0] != "EDGE2") {
      r.Fail("unknown record '" + t[0] + "' (TORO 2D: VERTEX2, EDGE2, EQUIV)");
    }
  });
  builder.SetPosesDeclared(any_vertex);
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    const Record r{path, line, t};
    if (t[0] != "EDGE2") return;
    r.Expect(12, "i j forward sideward rotate inf_ff inf_fs inf_ss inf_rr inf_fr inf_sr");
    const Pose2 delta = r.Delta(3, "forward", "sideward", "rotate");
    double v[6];
    for (int k = 0; k < 6; ++k) v[k] = r.Number(6 + k, "information");
    // TORO's order: ff fs ss rr fr sr.
    const Eigen::Matrix3d information = Symmetric3(v[0], v[1], v[4], v[2], v[5], v[3]);
    builder.AddEdge(r.Id(1, "pose i"), r.Id(2, "pose j"), delta,
                    CovarianceOfInformation<3>(information, r), r);
  });
  return builder.Finish();
}

LandmarkDataset ReadIsamLandmarks(const std::string& path) {
  Builder builder(path, "isam", /*poses_by_id=*/false);
  ForEachLandmarkRecord(path, [&](int line, const std::vector<std::string>& t) {
    const Record r{path, line, t};
    if (t[0] == "ODOMETRY" || t[0] == "EDGE2") {
      r.Expect(12, "i j dx dy dtheta sqrt-information xx xy xt yy yt tt");
      const Pose2 delta = r.Delta(3, "dx", "dy", "dtheta");
      Eigen::Matrix3d root = Eigen::Matrix3d::Zero();
      root(0, 0) = r.Number(6, "xx");
      root(0, 1) = r.Number(7, "xy");
      root(0, 2) = r.Number(8, "xt");
      root(1, 1) = r.Number(9, "yy");
      root(1, 2) = r.Number(10, "yt");
      root(2, 2) = r.Number(11, "tt");
      builder.AddEdge(r.Id(1, "pose i"), r.Id(2, "pose j"), delta,
                      CovarianceOfSqrtInformation<3>(root, r), r);
    } else if (t[0] == "LANDMARK") {
      r.Expect(8, "i l x y sqrt-information xx xy yy");
      Eigen::Matrix2d root = Eigen::Matrix2d::Zero();
      root(0, 0) = r.Number(5, "xx");
      root(0, 1) = r.Number(6, "xy");
      root(1, 1) = r.Number(7, "yy");
      builder.AddSighting(r.Id(1, "pose i"), r.Id(2, "landmark l"),
                          Eigen::Vector2d(r.Coordinate(3, "x"), r.Coordinate(4, "y")),
                          CovarianceOfSqrtInformation<2>(root, r), r);
    } else {
      r.Fail("unknown record '" + t[0] + "' (iSAM 2D: ODOMETRY or EDGE2, LANDMARK)");
    }
  });
  return builder.Finish();
}

LandmarkDataset ReadLandmarkDataset(const std::string& path, LandmarkFormat format,
                                    const LandmarkReadOptions& options) {
  switch (format) {
    case LandmarkFormat::kGtsam:
      return ReadGtsamLandmarks(path);
    case LandmarkFormat::kG2o:
      return ReadG2oLandmarks(path);
    case LandmarkFormat::kToro:
      return ReadToroGraph(path);
    case LandmarkFormat::kIsam:
      return ReadIsamLandmarks(path);
    case LandmarkFormat::kVictoriaRaw: {
      namespace fs = std::filesystem;
      const fs::path measurements =
          fs::is_directory(path) ? fs::path(path) / "measurements.dat" : fs::path(path);
      const std::string inputs = !options.inputs_path.empty()
                                     ? options.inputs_path
                                     : (measurements.parent_path() / "inputs.dat").string();
      return ReadVictoriaRaw(measurements.string(), inputs, options.raw);
    }
  }
  throw Error("unknown landmark format");
}

// ---------------------------------------------------------------------------

namespace {

std::string Num(double v) {
  char text[40];
  std::snprintf(text, sizeof(text), "%.17g", v);
  return text;
}

void CheckWritable(const LandmarkDataset& data, const std::string& path, bool needs_ids) {
  if (data.sensor_offset_m.norm() > 0)
    throw Error::InFile(path,
                        "the sensor is mounted off the robot's origin, which the format "
                        "cannot say");
  if (needs_ids)
    for (const LandmarkSighting& s : data.sightings)
      if (s.landmark < 0)
        throw Error::InFile(path, "a sighting without a landmark id (line " +
                                      std::to_string(s.line) + ") cannot be written");
}

Eigen::Vector2d PointOf(const LandmarkSighting& s) {
  return {s.range_m * std::cos(s.bearing_rad), s.range_m * std::sin(s.bearing_rad)};
}

// The (x, y) covariance of a sighting: its own, or the range-bearing noise
// carried to the point to first order.
Eigen::Matrix2d PointCovariance(const LandmarkSighting& s) {
  if (s.cartesian) return s.xy_covariance;
  const double c = std::cos(s.bearing_rad), sn = std::sin(s.bearing_rad);
  Eigen::Matrix2d j;
  j << c, -s.range_m * sn, sn, s.range_m * c;
  const Eigen::Vector2d variance(s.range_std_m * s.range_std_m,
                                 s.bearing_std_rad * s.bearing_std_rad);
  return j * variance.asDiagonal() * j.transpose();
}

template <int N>
Eigen::Matrix<double, N, N> Information(const Eigen::Matrix<double, N, N>& covariance) {
  Eigen::Matrix<double, N, N> i = covariance.llt().solve(Eigen::Matrix<double, N, N>::Identity());
  return 0.5 * (i + i.transpose());
}

// Upper-triangular R with R^T R the information.
template <int N>
Eigen::Matrix<double, N, N> SqrtInformation(const Eigen::Matrix<double, N, N>& covariance) {
  return Eigen::Matrix<double, N, N>(Information<N>(covariance).llt().matrixU());
}

std::string PoseLine(const char* tag, const RelativePoseMeasurement& e) {
  return std::string(tag) + " " + std::to_string(e.from) + " " + std::to_string(e.to) + " " +
         Num(e.delta.x) + " " + Num(e.delta.y) + " " + Num(e.delta.theta);
}

// The landmarks' vertex ids in g2o (after the poses') and positions placed
// at their first sighting by the dead reckoning.
std::map<int, Eigen::Vector2d> FirstPlacements(const LandmarkDataset& data) {
  std::map<int, Eigen::Vector2d> placed;
  for (const LandmarkSighting& s : data.sightings)
    if (!placed.count(s.landmark))
      placed[s.landmark] = LandmarkFromRangeBearing(data.dead_reckoning[s.pose], s.range_m,
                                                    s.bearing_rad, data.sensor_offset_m);
  return placed;
}

}  // namespace

void WriteG2oLandmarks(const LandmarkDataset& data, const std::string& path) {
  CheckWritable(data, path, true);
  std::ostringstream out;
  out << "# g2o 2D: poses 0.." << data.num_poses - 1 << ", landmark l as vertex " << data.num_poses
      << " + l\n";
  for (int i = 0; i < data.num_poses; ++i) {
    const Pose2& p = data.dead_reckoning[i];
    out << "VERTEX_SE2 " << i << ' ' << Num(p.x) << ' ' << Num(p.y) << ' ' << Num(p.theta) << '\n';
  }
  for (const auto& [id, p] : FirstPlacements(data))
    out << "VERTEX_XY " << data.num_poses + static_cast<long>(id) << ' ' << Num(p.x()) << ' '
        << Num(p.y()) << '\n';
  out << "FIX 0\n";
  for (const RelativePoseMeasurement& e : data.odometry) {
    const Eigen::Matrix3d i = Information<3>(e.covariance);
    out << PoseLine("EDGE_SE2", e) << ' ' << Num(i(0, 0)) << ' ' << Num(i(0, 1)) << ' '
        << Num(i(0, 2)) << ' ' << Num(i(1, 1)) << ' ' << Num(i(1, 2)) << ' ' << Num(i(2, 2))
        << '\n';
  }
  for (const LandmarkSighting& s : data.sightings) {
    const Eigen::Vector2d z = PointOf(s);
    const Eigen::Matrix2d i = Information<2>(PointCovariance(s));
    out << "EDGE_SE2_XY " << s.pose << ' ' << data.num_poses + static_cast<long>(s.landmark) << ' '
        << Num(z.x()) << ' ' << Num(z.y()) << ' ' << Num(i(0, 0)) << ' ' << Num(i(0, 1)) << ' '
        << Num(i(1, 1)) << '\n';
  }
  WriteTextFileAtomically(path, out.str());
}

void WriteToroGraph(const LandmarkDataset& data, const std::string& path) {
  CheckWritable(data, path, false);
  std::ostringstream out;
  for (int i = 0; i < data.num_poses; ++i) {
    const Pose2& p = data.dead_reckoning[i];
    out << "VERTEX2 " << i << ' ' << Num(p.x) << ' ' << Num(p.y) << ' ' << Num(p.theta) << '\n';
  }
  for (const RelativePoseMeasurement& e : data.odometry) {
    const Eigen::Matrix3d i = Information<3>(e.covariance);
    out << PoseLine("EDGE2", e) << ' ' << Num(i(0, 0)) << ' ' << Num(i(0, 1)) << ' ' << Num(i(1, 1))
        << ' ' << Num(i(2, 2)) << ' ' << Num(i(0, 2)) << ' ' << Num(i(1, 2)) << '\n';
  }
  WriteTextFileAtomically(path, out.str());
}

namespace {

// The indices of the sightings made at each pose.
std::vector<std::vector<int>> SightingsByPose(const LandmarkDataset& data) {
  std::vector<std::vector<int>> at(data.num_poses);
  for (size_t k = 0; k < data.sightings.size(); ++k)
    at[data.sightings[k].pose].push_back(static_cast<int>(k));
  return at;
}

}  // namespace

void WriteIsamLandmarks(const LandmarkDataset& data, const std::string& path) {
  CheckWritable(data, path, true);
  std::ostringstream out;
  // Sightings after the first edge reaching their pose (iSAM numbers poses
  // as the odometry reaches them).
  std::vector<std::vector<int>> at = SightingsByPose(data);
  auto sightings = [&](int pose) {
    for (int k : at[pose]) {
      const LandmarkSighting& s = data.sightings[k];
      const Eigen::Vector2d z = PointOf(s);
      const Eigen::Matrix2d r = SqrtInformation<2>(PointCovariance(s));
      out << "LANDMARK " << s.pose << ' ' << s.landmark << ' ' << Num(z.x()) << ' ' << Num(z.y())
          << ' ' << Num(r(0, 0)) << ' ' << Num(r(0, 1)) << ' ' << Num(r(1, 1)) << '\n';
    }
    at[pose].clear();
  };
  if (data.odometry.empty()) throw Error::InFile(path, "no odometry to write");
  for (const RelativePoseMeasurement& e : data.odometry) {
    const Eigen::Matrix3d r = SqrtInformation<3>(e.covariance);
    out << PoseLine("EDGE2", e) << ' ' << Num(r(0, 0)) << ' ' << Num(r(0, 1)) << ' ' << Num(r(0, 2))
        << ' ' << Num(r(1, 1)) << ' ' << Num(r(1, 2)) << ' ' << Num(r(2, 2)) << '\n';
    sightings(std::min(e.from, e.to));
    sightings(std::max(e.from, e.to));
  }
  WriteTextFileAtomically(path, out.str());
}

void WriteGtsamLandmarks(const LandmarkDataset& data, const std::string& path) {
  CheckWritable(data, path, true);
  std::ostringstream out;
  std::vector<std::vector<int>> at = SightingsByPose(data);
  auto sightings = [&](int pose) {
    for (int k : at[pose]) {
      const LandmarkSighting& s = data.sightings[k];
      if (s.cartesian) {
        const Eigen::Vector2d z = PointOf(s);
        const Eigen::Matrix2d& c = s.xy_covariance;
        out << "LANDMARK " << s.pose << ' ' << s.landmark << ' ' << Num(z.x()) << ' ' << Num(z.y())
            << ' ' << Num(c(0, 0)) << ' ' << Num(c(0, 1)) << ' ' << Num(c(1, 1)) << '\n';
      } else {
        out << "BR " << s.pose << ' ' << s.landmark << ' ' << Num(s.bearing_rad) << ' '
            << Num(s.range_m) << ' ' << Num(s.bearing_std_rad) << ' ' << Num(s.range_std_m) << '\n';
      }
    }
    at[pose].clear();
  };
  if (data.odometry.empty()) throw Error::InFile(path, "no odometry to write");
  for (const RelativePoseMeasurement& e : data.odometry) {
    const Eigen::Matrix3d& c = e.covariance;
    out << PoseLine("ODOMETRY", e) << ' ' << Num(c(0, 0)) << ' ' << Num(c(0, 1)) << ' '
        << Num(c(0, 2)) << ' ' << Num(c(1, 1)) << ' ' << Num(c(1, 2)) << ' ' << Num(c(2, 2))
        << '\n';
    sightings(std::min(e.from, e.to));
    sightings(std::max(e.from, e.to));
  }
  WriteTextFileAtomically(path, out.str());
}

void WriteLandmarkDataset(const LandmarkDataset& data, LandmarkFormat format,
                          const std::string& path) {
  switch (format) {
    case LandmarkFormat::kGtsam:
      return WriteGtsamLandmarks(data, path);
    case LandmarkFormat::kG2o:
      return WriteG2oLandmarks(data, path);
    case LandmarkFormat::kToro:
      return WriteToroGraph(data, path);
    case LandmarkFormat::kIsam:
      return WriteIsamLandmarks(data, path);
    case LandmarkFormat::kVictoriaRaw:
      break;
  }
  throw Error::InFile(path, "the victoria-raw format is read only");
}

}  // namespace oslam
