#include "calib/calibration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/hyperbolic_camera.h"
#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/statistics.h"

namespace oslam {

using Vector6d = Eigen::Matrix<double, 6, 1>;

std::vector<Eigen::Vector3d> BoardPattern::ObjectPoints() const {
  std::vector<Eigen::Vector3d> points;
  points.reserve(static_cast<size_t>(cols) * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) points.emplace_back(c * square_m, r * square_m, 0.0);
  return points;
}

bool CalibrationOptions::Validate(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (model != "mei" && model != "hyperbolic")
    return fail("model must be mei or hyperbolic, got '" + model + "'");
  if (!(mirror_a_m > 0)) return fail("mirror_a_m must be positive");
  if (!(mirror_b_m >= 0) || !std::isfinite(mirror_b_m))
    return fail("mirror_b_m must be >= 0 (0: estimate)");
  if (!(focus_height_m > 0) || !std::isfinite(focus_height_m))
    return fail("focus_height_m must be positive");
  if (!std::isfinite(mount_yaw_rad)) return fail("mount_yaw_rad must be finite");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  if (!(function_tolerance > 0)) return fail("function_tolerance must be positive");
  if (!(outlier_view_factor > 1)) return fail("outlier_view_factor must be > 1");
  return true;
}

std::string CalibrationSummary::BriefReport() const {
  char text[256];
  std::snprintf(text, sizeof(text),
                "LM: %d iterations, %d views, %d corners, RMS %.4f -> %.4f px, %.2f s (%s)",
                iterations, views_used, points_used, initial_rms_px, final_rms_px, seconds,
                termination.c_str());
  return text;
}

bool DetectBoardCorners(const cv::Mat& image, const BoardPattern& pattern,
                        const CornerDetectionOptions& options, Corners* corners) {
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4)
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  else
    gray = image;
  std::vector<cv::Point2f> points;
  const cv::Size size(pattern.cols, pattern.rows);
  bool found = cv::findChessboardCornersSB(gray, size, points, cv::CALIB_CB_ACCURACY);
  if (!found)
    found = cv::findChessboardCornersSB(gray, size, points,
                                        cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
  if (!found || static_cast<int>(points.size()) != pattern.cols * pattern.rows) return false;
  if (options.refine_with_corner_subpix) {
    double spacing = std::numeric_limits<double>::infinity();
    for (int r = 0; r < pattern.rows; ++r)
      for (int c = 0; c < pattern.cols; ++c) {
        const cv::Point2f& p = points[r * pattern.cols + c];
        if (c + 1 < pattern.cols)
          spacing = std::min(spacing, cv::norm(points[r * pattern.cols + c + 1] - p));
        if (r + 1 < pattern.rows)
          spacing = std::min(spacing, cv::norm(points[(r + 1) * pattern.cols + c] - p));
      }
    const int half =
        static_cast<int>(std::clamp(options.subpix_window_fraction * spacing, 2.0, 6.0));
    cv::cornerSubPix(gray, points, cv::Size(half, half), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
  }
  corners->clear();
  for (const cv::Point2f& p : points) corners->emplace_back(p.x, p.y);
  return true;
}

namespace {

enum class Model { kMei, kHyperbolic };

Eigen::Matrix3d RotationOf(const Eigen::Vector3d& rotation) {
  const double angle = rotation.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix();
}

Eigen::Vector3d AngleAxisOf(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd angle_axis(rotation);
  return angle_axis.angle() * angle_axis.axis();
}

// Full intrinsic vectors:
//   Mei:        xi fx fy skew cx cy k1 k2 p1 p2
//   hyperbolic: focal_px cx cy mirror_a_m mirror_b_m
const std::vector<std::string> kMeiNames = {"xi",    "fx_px", "fy_px", "skew_px", "cx_px",
                                            "cy_px", "k1",    "k2",    "p1",      "p2"};
const std::vector<std::string> kHyperbolicNames = {"focal_px", "center_x_px", "center_y_px",
                                                   "mirror_a_m", "mirror_b_m"};

MeiParameters MeiFromVector(const Eigen::VectorXd& v) {
  MeiParameters p;
  p.xi = v[0];
  p.fx_px = v[1];
  p.fy_px = v[2];
  p.skew = v[3];
  p.cx_px = v[4];
  p.cy_px = v[5];
  p.k1 = v[6];
  p.k2 = v[7];
  p.p1 = v[8];
  p.p2 = v[9];
  return p;
}

Eigen::VectorXd VectorFromMei(const MeiParameters& p) {
  Eigen::VectorXd v(10);
  v << p.xi, p.fx_px, p.fy_px, p.skew, p.cx_px, p.cy_px, p.k1, p.k2, p.p1, p.p2;
  return v;
}

// Mirror parameters of a hyperbolic intrinsic vector (focus height 1 m, the
// image not mirrored: the caller mounts the camera).
HyperbolicMirrorParameters HyperbolicFromVector(const Eigen::VectorXd& v) {
  HyperbolicMirrorParameters p;
  p.focal_px = v[0];
  p.center_x_px = v[1];
  p.center_y_px = v[2];
  p.mirror_a_m = v[3];
  p.mirror_b_m = v[4];
  p.focus_height_m = 1.0;
  return p;
}

// Projects mirror-frame points for one intrinsic vector.
class Projector {
 public:
  Projector(Model model, const Eigen::VectorXd& intrinsics) : model_(model) {
    if (model == Model::kMei) {
      mei_.set_parameters(MeiFromVector(intrinsics));
    } else {
      const HyperbolicMirrorParameters p = HyperbolicFromVector(intrinsics);
      hyperbolic_.set_parameters(p);
      valid_ = p.focal_px > 0 && p.mirror_b_m > 0;
    }
  }
  // Mirror frame: z towards the camera (Mei convention); the hyperbolic
  // frame of docs/method.md §4.3 is (x, -y, -z) with a mirrored image.
  bool Project(const Eigen::Vector3d& point, Eigen::Vector2d* pixel) const {
    if (model_ == Model::kMei) return mei_.ProjectMirrorPoint(point, pixel);
    if (!valid_) return false;
    const double range = std::hypot(point.x(), point.y());
    if (!(range > 0)) return false;
    double radius = 0;
    const double focus = hyperbolic_.parameters().focus_height_m;
    if (!hyperbolic_.ImageRadius(range, focus - point.z(), &radius)) return false;
    *pixel = hyperbolic_.ImageCenter() + radius * Eigen::Vector2d(point.x(), point.y()) / range;
    return true;
  }

 private:
  Model model_;
  MeiCamera mei_;
  HyperbolicCamera hyperbolic_;
  bool valid_ = true;
};

struct Problem {
  Model model = Model::kMei;
  Eigen::VectorXd intrinsics;  // full vector
  std::vector<int> free;       // indices of estimated intrinsics
  std::vector<Eigen::Vector3d> object;
  std::vector<const Corners*> observed;  // one per used view
  std::vector<Vector6d> poses;           // rotation (angle-axis), translation

  int NumResiduals() const { return static_cast<int>(2 * object.size() * observed.size()); }
  int NumParameters() const { return static_cast<int>(free.size() + 6 * poses.size()); }

  Eigen::VectorXd State() const {
    Eigen::VectorXd x(NumParameters());
    for (size_t i = 0; i < free.size(); ++i) x[i] = intrinsics[free[i]];
    for (size_t v = 0; v < poses.size(); ++v) x.segment<6>(free.size() + 6 * v) = poses[v];
    return x;
  }
  void SetState(const Eigen::VectorXd& x) {
    for (size_t i = 0; i < free.size(); ++i) intrinsics[free[i]] = x[i];
    for (size_t v = 0; v < poses.size(); ++v) poses[v] = x.segment<6>(free.size() + 6 * v);
  }
  // Residuals (reprojected - observed) of view v; false when a point has no image.
  bool ViewResiduals(const Projector& projector, const Vector6d& pose, size_t v,
                     Eigen::VectorXd* residuals) const {
    const Eigen::Matrix3d rotation = RotationOf(pose.head<3>());
    residuals->resize(2 * object.size());
    for (size_t i = 0; i < object.size(); ++i) {
      Eigen::Vector2d pixel;
      if (!projector.Project(rotation * object[i] + pose.tail<3>(), &pixel)) return false;
      residuals->segment<2>(2 * i) = pixel - (*observed[v])[i];
    }
    return true;
  }
  bool Residuals(Eigen::VectorXd* residuals) const {
    const Projector projector(model, intrinsics);
    residuals->resize(NumResiduals());
    Eigen::VectorXd view;
    for (size_t v = 0; v < observed.size(); ++v) {
      if (!ViewResiduals(projector, poses[v], v, &view)) return false;
      residuals->segment(v * 2 * object.size(), view.size()) = view;
    }
    return true;
  }
  // Central-difference Jacobian, block-sparse per view but stored dense.
  Eigen::MatrixXd Jacobian() const {
    const int rows_per_view = static_cast<int>(2 * object.size());
    Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(NumResiduals(), NumParameters());
    Eigen::VectorXd plus, minus;
    const Projector projector(model, intrinsics);
    for (size_t k = 0; k < free.size(); ++k) {
      const double step = 1e-6 * std::max(1e-2, std::abs(intrinsics[free[k]]));
      Eigen::VectorXd up = intrinsics, down = intrinsics;
      up[free[k]] += step;
      down[free[k]] -= step;
      const Projector projector_up(model, up), projector_down(model, down);
      for (size_t v = 0; v < observed.size(); ++v) {
        if (ViewResiduals(projector_up, poses[v], v, &plus) &&
            ViewResiduals(projector_down, poses[v], v, &minus)) {
          jacobian.block(v * rows_per_view, k, rows_per_view, 1) = (plus - minus) / (2 * step);
        }
      }
    }
    for (size_t v = 0; v < observed.size(); ++v) {
      for (int k = 0; k < 6; ++k) {
        const double step = k < 3 ? 1e-7 : 1e-7 * std::max(0.1, poses[v].tail<3>().norm());
        Vector6d up = poses[v], down = poses[v];
        up[k] += step;
        down[k] -= step;
        if (ViewResiduals(projector, up, v, &plus) && ViewResiduals(projector, down, v, &minus)) {
          jacobian.block(v * rows_per_view, free.size() + 6 * v + k, rows_per_view, 1) =
              (plus - minus) / (2 * step);
        }
      }
    }
    return jacobian;
  }
};

double RmsOf(const Eigen::VectorXd& residuals) {
  return residuals.size() ? std::sqrt(residuals.squaredNorm() / (residuals.size() / 2)) : 0.0;
}

struct SolveReport {
  int iterations = 0;
  double initial_rms = 0, final_rms = 0;
  std::string termination;
};

SolveReport SolveLevenbergMarquardt(Problem* problem, int max_iterations, double tolerance) {
  SolveReport report;
  Eigen::VectorXd residuals;
  if (!problem->Residuals(&residuals)) {
    report.termination = "initial estimate has corners without image";
    report.initial_rms = report.final_rms = std::numeric_limits<double>::infinity();
    return report;
  }
  double cost = residuals.squaredNorm();
  report.initial_rms = RmsOf(residuals);
  double lambda = 1e-3;
  report.termination = "max iterations";
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    report.iterations = iteration + 1;
    const Eigen::MatrixXd jacobian = problem->Jacobian();
    const Eigen::MatrixXd jtj = jacobian.transpose() * jacobian;
    const Eigen::VectorXd jtr = jacobian.transpose() * residuals;
    const Eigen::VectorXd x = problem->State();
    bool accepted = false;
    double new_cost = cost;
    Eigen::VectorXd step;
    while (lambda < 1e12) {
      Eigen::MatrixXd damped = jtj;
      damped.diagonal() += lambda * jtj.diagonal().cwiseMax(1e-9);
      step = damped.ldlt().solve(-jtr);
      problem->SetState(x + step);
      Eigen::VectorXd trial;
      if (step.allFinite() && problem->Residuals(&trial) && trial.squaredNorm() < cost) {
        new_cost = trial.squaredNorm();
        residuals = trial;
        accepted = true;
        lambda = std::max(1e-12, lambda / 3.0);
        break;
      }
      lambda *= 4.0;
    }
    if (!accepted) {
      problem->SetState(x);
      report.termination = "converged (no decreasing step)";
      break;
    }
    const double decrease = (cost - new_cost) / cost;
    cost = new_cost;
    if (decrease < tolerance || step.norm() < 1e-12 * (x.norm() + 1e-12)) {
      report.termination = "converged";
      break;
    }
  }
  report.final_rms = RmsOf(residuals);
  return report;
}

// Board pose from unit rays (mirror frame) by a DLT on the plane homography
// H = [r1 r2 t] with ray × (H p) = 0. False when degenerate.
bool PoseFromRays(const std::vector<Eigen::Vector3d>& object,
                  const std::vector<Eigen::Vector3d>& rays, Vector6d* pose) {
  const size_t n = object.size();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : object) mean += p.head<2>();
  mean /= static_cast<double>(n);
  double spread = 0;
  for (const auto& p : object) spread += (p.head<2>() - mean).norm();
  spread = std::max(spread / n, 1e-12);
  Eigen::Matrix3d normalise;
  normalise << 1 / spread, 0, -mean.x() / spread, 0, 1 / spread, -mean.y() / spread, 0, 0, 1;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n, 9);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d q = normalise * Eigen::Vector3d(object[i].x(), object[i].y(), 1.0);
    const Eigen::Vector3d& d = rays[i];
    // d × (H q) = [d]x (H q); H q = kron rows: (H q)_r = h_r · q.
    Eigen::Matrix3d skew;
    skew << 0, -d.z(), d.y(), d.z(), 0, -d.x(), -d.y(), d.x(), 0;
    for (int row = 0; row < 3; ++row)
      for (int r = 0; r < 3; ++r) a.block<1, 3>(3 * i + row, 3 * r) = skew(row, r) * q.transpose();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d homography;
  homography << h.segment<3>(0).transpose(), h.segment<3>(3).transpose(),
      h.segment<3>(6).transpose();
  homography = homography * normalise;
  int positive = 0;
  for (size_t i = 0; i < n; ++i)
    positive += rays[i].dot(homography * Eigen::Vector3d(object[i].x(), object[i].y(), 1.0)) > 0;
  if (2 * positive < static_cast<int>(n)) homography = -homography;
  const double scale = 2.0 / (homography.col(0).norm() + homography.col(1).norm());
  if (!std::isfinite(scale)) return false;
  Eigen::Matrix3d rotation;
  rotation.col(0) = homography.col(0) * scale;
  rotation.col(1) = homography.col(1) * scale;
  rotation.col(2) = rotation.col(0).cross(rotation.col(1));
  Eigen::JacobiSVD<Eigen::Matrix3d> rsvd(rotation, Eigen::ComputeFullU | Eigen::ComputeFullV);
  rotation = rsvd.matrixU() * rsvd.matrixV().transpose();
  if (rotation.determinant() < 0) {
    Eigen::Matrix3d u = rsvd.matrixU();
    u.col(2) = -u.col(2);
    rotation = u * rsvd.matrixV().transpose();
  }
  pose->head<3>() = AngleAxisOf(rotation);
  pose->tail<3>() = homography.col(2) * scale;
  return pose->allFinite();
}

// Poses of every view by DLT on rays back-projected with `camera`; false when
// a corner does not back-project.
bool InitialPoses(const MeiCamera& camera, const std::vector<Eigen::Vector3d>& object,
                  const std::vector<const Corners*>& observed, std::vector<Vector6d>* poses) {
  poses->assign(observed.size(), Vector6d::Zero());
  std::vector<Eigen::Vector3d> rays(object.size());
  for (size_t v = 0; v < observed.size(); ++v) {
    for (size_t i = 0; i < object.size(); ++i)
      if (!camera.BackProjectToMirror((*observed[v])[i], &rays[i])) return false;
    if (!PoseFromRays(object, rays, &(*poses)[v])) return false;
  }
  return true;
}

// Mei initial guess: ξ = 1, no distortion, centre given, generalised focal
// length γ chosen on a log grid by the median per-view RMS of DLT poses.
Problem InitialMeiProblem(const std::vector<Eigen::Vector3d>& object,
                          const std::vector<const Corners*>& observed, double cx, double cy,
                          int image_width, int image_height) {
  Problem best;
  double best_score = std::numeric_limits<double>::infinity();
  const double half_diagonal = 0.5 * std::hypot(image_width, image_height);
  for (int g = 0; g <= 80; ++g) {
    const double gamma = half_diagonal * 0.05 * std::pow(40.0, g / 80.0);
    MeiParameters p;
    p.xi = 1.0;
    p.fx_px = p.fy_px = gamma;
    p.cx_px = cx;
    p.cy_px = cy;
    MeiCamera camera(p, image_width, image_height, {});
    Problem problem;
    problem.model = Model::kMei;
    problem.intrinsics = VectorFromMei(p);
    problem.object = object;
    problem.observed = observed;
    if (!InitialPoses(camera, object, observed, &problem.poses)) continue;
    const Projector projector(Model::kMei, problem.intrinsics);
    std::vector<double> view_rms;
    Eigen::VectorXd residuals;
    for (size_t v = 0; v < observed.size(); ++v)
      view_rms.push_back(problem.ViewResiduals(projector, problem.poses[v], v, &residuals)
                             ? RmsOf(residuals)
                             : std::numeric_limits<double>::infinity());
    const double score = UpperMedian(view_rms);
    if (score < best_score) {
      best_score = score;
      best = problem;
    }
  }
  if (!std::isfinite(best_score))
    throw Error("calibration: no initial focal length fits the corners");
  return best;
}

// The views whose board was found, as corner lists (same order as `used`).
void UsedViews(const std::vector<CalibrationView>& views, size_t corners_per_view,
               std::vector<const Corners*>* observed, std::vector<size_t>* used) {
  for (size_t v = 0; v < views.size(); ++v) {
    if (!views[v].board_found) continue;
    if (views[v].corners.size() != corners_per_view)
      throw Error("calibration: view " + views[v].name + " has " +
                  std::to_string(views[v].corners.size()) + " corners, expected " +
                  std::to_string(corners_per_view));
    observed->push_back(&views[v].corners);
    used->push_back(v);
  }
  if (observed->size() < 3)
    throw Error("calibration: need at least 3 views with a detected board, got " +
                std::to_string(observed->size()));
}

// The Mei model fitted to every view (also the initial guess of the
// hyperbolic model).
Problem FitMei(const std::vector<Eigen::Vector3d>& object,
               const std::vector<const Corners*>& observed, int image_width, int image_height,
               const CalibrationOptions& options, SolveReport* report) {
  const double cx =
      std::isfinite(options.initial_cx_px) ? options.initial_cx_px : 0.5 * (image_width - 1);
  const double cy =
      std::isfinite(options.initial_cy_px) ? options.initial_cy_px : 0.5 * (image_height - 1);
  Problem problem = InitialMeiProblem(object, observed, cx, cy, image_width, image_height);
  problem.free = {0, 1, 2, 4, 5};
  if (!options.fix_skew) problem.free.push_back(3);
  if (options.estimate_distortion && options.model == "mei")
    for (int k : {6, 7, 8, 9}) problem.free.push_back(k);
  std::sort(problem.free.begin(), problem.free.end());
  *report = SolveLevenbergMarquardt(&problem, options.max_iterations, options.function_tolerance);
  return problem;
}

// Radial profile of a Mei fit: the elevation of each corner's ray (in the
// hyperbolic frame, z up) and its image radius.
std::vector<std::pair<double, double>> RadialProfile(const Problem& mei_fit) {
  const MeiParameters mei = MeiFromVector(mei_fit.intrinsics);
  std::vector<std::pair<double, double>> profile;
  for (size_t v = 0; v < mei_fit.observed.size(); ++v) {
    const Eigen::Matrix3d rotation = RotationOf(mei_fit.poses[v].head<3>());
    for (size_t i = 0; i < mei_fit.object.size(); ++i) {
      const Eigen::Vector3d p = rotation * mei_fit.object[i] + mei_fit.poses[v].tail<3>();
      profile.emplace_back(
          std::atan2(-p.z(), std::hypot(p.x(), p.y())),
          ((*mei_fit.observed[v])[i] - Eigen::Vector2d(mei.cx_px, mei.cy_px)).norm());
    }
  }
  return profile;
}

// For each mirror b/a candidate the focal length is a linear least-squares
// fit of the profile; the best b and its focal length. False when none fits.
bool BestMirrorForProfile(const std::vector<std::pair<double, double>>& profile, double a,
                          const std::vector<double>& candidates, int image_width, int image_height,
                          double* best_b, double* best_f) {
  double best_error = std::numeric_limits<double>::infinity();
  for (double b : candidates) {
    HyperbolicMirrorParameters hp;
    hp.mirror_a_m = a;
    hp.mirror_b_m = b;
    hp.focal_px = 1.0;
    hp.focus_height_m = 1.0;
    HyperbolicCamera unit(hp, image_width, image_height, {});
    double sum_rg = 0, sum_gg = 0;
    std::vector<double> g;
    bool ok = true;
    for (const auto& [elevation, radius] : profile) {
      double value = 0;
      if (!unit.ImageRadius(std::cos(elevation), 1.0 + std::sin(elevation), &value)) {
        ok = false;
        break;
      }
      g.push_back(value);
      sum_rg += radius * value;
      sum_gg += value * value;
    }
    if (!ok || !(sum_gg > 0)) continue;
    const double f = sum_rg / sum_gg;
    double error = 0;
    for (size_t i = 0; i < g.size(); ++i) error += std::pow(profile[i].second - f * g[i], 2);
    if (error < best_error) {
      best_error = error;
      *best_b = b;
      *best_f = f;
    }
  }
  return std::isfinite(best_error);
}

// The hyperbolic model started from a Mei fit: mirror b (unless given) and
// focal length from its radial profile, then refined with the Mei fit's poses.
Problem FitHyperbolicFromMei(const Problem& mei_fit, int image_width, int image_height,
                             const CalibrationOptions& options, SolveReport* report) {
  const double a = options.mirror_a_m;
  std::vector<double> candidates;
  if (options.mirror_b_m > 0)
    candidates = {options.mirror_b_m};
  else
    for (int k = 0; k <= 120; ++k) candidates.push_back(a * 0.05 * std::pow(100.0, k / 120.0));
  double best_b = options.mirror_b_m, best_f = 0;
  if (!BestMirrorForProfile(RadialProfile(mei_fit), a, candidates, image_width, image_height,
                            &best_b, &best_f))
    throw Error("calibration: no hyperbolic mirror fits the Mei profile of these views");
  const MeiParameters mei = MeiFromVector(mei_fit.intrinsics);
  Problem hyperbolic;
  hyperbolic.model = Model::kHyperbolic;
  hyperbolic.intrinsics.resize(5);
  hyperbolic.intrinsics << best_f, mei.cx_px, mei.cy_px, a, best_b;
  hyperbolic.free = {0, 1, 2};
  if (!(options.mirror_b_m > 0)) hyperbolic.free.push_back(4);
  hyperbolic.object = mei_fit.object;
  hyperbolic.observed = mei_fit.observed;
  hyperbolic.poses = mei_fit.poses;
  *report =
      SolveLevenbergMarquardt(&hyperbolic, options.max_iterations, options.function_tolerance);
  return hyperbolic;
}

// Per-view RMS, reprojected corners and outlier flags of the fitted views
// (`used[k]` is the index in result->views of the problem's view k).
void ScoreViews(const Problem& problem, const std::vector<size_t>& used,
                const CalibrationOptions& options, CalibrationResult* result) {
  const Projector projector(problem.model, problem.intrinsics);
  std::vector<double> view_rms;
  Eigen::VectorXd residuals;
  for (size_t k = 0; k < used.size(); ++k) {
    CalibrationView& view = result->views[used[k]];
    problem.ViewResiduals(projector, problem.poses[k], k, &residuals);
    view.rms_px = RmsOf(residuals);
    view.rotation_mirror_from_board = problem.poses[k].head<3>();
    view.translation_mirror_from_board_m = problem.poses[k].tail<3>();
    view.reprojected.clear();
    for (size_t i = 0; i < problem.object.size(); ++i)
      view.reprojected.push_back(view.corners[i] + residuals.segment<2>(2 * i));
    view_rms.push_back(view.rms_px);
  }
  const double median = UpperMedian(view_rms);
  for (size_t k : used)
    result->views[k].outlier =
        result->views[k].rms_px > std::max(options.outlier_view_factor * median, 1.0);
}

// The estimated intrinsics with their standard deviations:
// sigma² (JᵀJ)⁻¹ with sigma² = |r|² / (m - n).
void EstimatedParameters(const Problem& problem, const std::vector<std::string>& names,
                         CalibrationResult* result) {
  const Eigen::MatrixXd jacobian = problem.Jacobian();
  Eigen::VectorXd all_residuals;
  problem.Residuals(&all_residuals);
  const int dof = std::max(1, problem.NumResiduals() - problem.NumParameters());
  const double sigma_sq = all_residuals.squaredNorm() / dof;
  const Eigen::MatrixXd covariance =
      sigma_sq *
      (jacobian.transpose() * jacobian)
          .ldlt()
          .solve(Eigen::MatrixXd::Identity(problem.NumParameters(), problem.NumParameters()));
  result->parameter_names.clear();
  result->parameters.resize(problem.free.size());
  result->standard_deviations.resize(problem.free.size());
  for (size_t i = 0; i < problem.free.size(); ++i) {
    result->parameter_names.push_back(names[problem.free[i]]);
    result->parameters[i] = problem.intrinsics[problem.free[i]];
    result->standard_deviations[i] = std::sqrt(std::max(0.0, covariance(i, i)));
  }
}

// The calibrated camera, mounted with the mirror axis vertical at the given
// height and turned by `mount_yaw_rad` about it, with a first annulus from the
// centre to the farthest image corner (the rim detector refines it).
std::unique_ptr<CameraModel> CalibratedCamera(const Problem& problem, int image_width,
                                              int image_height, double focus_height_m,
                                              double mount_yaw_rad) {
  std::unique_ptr<CameraModel> camera;
  if (problem.model == Model::kMei) {
    MeiParameters p = MeiFromVector(problem.intrinsics);
    p.focus_height_m = focus_height_m;
    p.mount_yaw_rad = mount_yaw_rad;
    camera = MeiCamera(p, image_width, image_height, {}).Clone();
  } else {
    HyperbolicMirrorParameters p = HyperbolicFromVector(problem.intrinsics);
    p.focus_height_m = focus_height_m;
    p.flip_image_angle = true;
    // Image angle = offset + s·bearing (s = -1, flipped): a camera turned by
    // the yaw shows robot bearing b where the unturned one shows b - yaw.
    p.angle_offset_rad = WrapAngle(p.angle_offset_rad + mount_yaw_rad);
    camera = HyperbolicCamera(p, image_width, image_height, {}).Clone();
  }
  const Eigen::Vector2d centre = camera->ImageCenter();
  double far = 0;
  for (double x : {0.0, image_width - 1.0})
    for (double y : {0.0, image_height - 1.0})
      far = std::max(far, (Eigen::Vector2d(x, y) - centre).norm());
  camera->set_annulus({0.0, far});
  return camera;
}

}  // namespace

CalibrationResult CalibrateFromCorners(const std::vector<CalibrationView>& views,
                                       const BoardPattern& pattern, int image_width,
                                       int image_height, const CalibrationOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("calibration options: " + why);
  if (pattern.cols < 2 || pattern.rows < 2 || !(pattern.square_m > 0))
    throw Error("calibration: bad board pattern");
  const auto start = std::chrono::steady_clock::now();
  const std::vector<Eigen::Vector3d> object = pattern.ObjectPoints();
  std::vector<const Corners*> observed;
  std::vector<size_t> used;
  UsedViews(views, object.size(), &observed, &used);

  SolveReport report;
  Problem problem = FitMei(object, observed, image_width, image_height, options, &report);
  std::vector<std::string> names = kMeiNames;
  if (options.model == "hyperbolic") {
    problem = FitHyperbolicFromMei(problem, image_width, image_height, options, &report);
    names = kHyperbolicNames;
  }

  CalibrationResult result;
  result.views = views;
  ScoreViews(problem, used, options, &result);
  EstimatedParameters(problem, names, &result);
  result.camera = CalibratedCamera(problem, image_width, image_height, options.focus_height_m,
                                   options.mount_yaw_rad);
  result.summary.iterations = report.iterations;
  result.summary.views_used = static_cast<int>(used.size());
  result.summary.points_used = static_cast<int>(used.size() * object.size());
  result.summary.initial_rms_px = report.initial_rms;
  result.summary.final_rms_px = report.final_rms;
  result.summary.termination = report.termination;
  result.summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

double MeiRmsWithFixedIntrinsics(const MeiCamera& camera, const std::vector<CalibrationView>& views,
                                 const BoardPattern& pattern) {
  Problem problem;
  problem.model = Model::kMei;
  problem.intrinsics = VectorFromMei(camera.parameters());
  problem.object = pattern.ObjectPoints();
  for (const CalibrationView& view : views)
    if (view.board_found) problem.observed.push_back(&view.corners);
  if (problem.observed.empty()) return 0.0;
  if (!InitialPoses(camera, problem.object, problem.observed, &problem.poses))
    return std::numeric_limits<double>::infinity();
  return SolveLevenbergMarquardt(&problem, 100, 1e-12).final_rms;
}

OpenCvOmnidirResult CalibrateWithOpenCvOmnidir(const std::vector<CalibrationView>& views,
                                               const BoardPattern& pattern, int image_width,
                                               int image_height, bool fix_skew) {
  OpenCvOmnidirResult result;
  std::vector<cv::Mat> object_points, image_points;
  std::vector<int> view_of;
  const std::vector<Eigen::Vector3d> object = pattern.ObjectPoints();
  for (size_t v = 0; v < views.size(); ++v) {
    if (!views[v].board_found) continue;
    cv::Mat obj(1, static_cast<int>(object.size()), CV_64FC3);
    cv::Mat img(1, static_cast<int>(object.size()), CV_64FC2);
    for (size_t i = 0; i < object.size(); ++i) {
      obj.at<cv::Vec3d>(0, i) = cv::Vec3d(object[i].x(), object[i].y(), object[i].z());
      img.at<cv::Vec2d>(0, i) = cv::Vec2d(views[v].corners[i].x(), views[v].corners[i].y());
    }
    object_points.push_back(obj);
    image_points.push_back(img);
    view_of.push_back(static_cast<int>(v));
  }
  const auto start = std::chrono::steady_clock::now();
  try {
    cv::Mat k, xi, d, idx;
    std::vector<cv::Mat> rvecs, tvecs;
    const int flags = fix_skew ? cv::omnidir::CALIB_FIX_SKEW : 0;
    result.rms_px = cv::omnidir::calibrate(
        object_points, image_points, cv::Size(image_width, image_height), k, xi, d, rvecs, tvecs,
        flags, cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-8), idx);
    result.ok = true;
    MeiParameters& p = result.parameters;
    p.xi = xi.at<double>(0);
    p.fx_px = k.at<double>(0, 0);
    p.skew = k.at<double>(0, 1);
    p.cx_px = k.at<double>(0, 2);
    p.fy_px = k.at<double>(1, 1);
    p.cy_px = k.at<double>(1, 2);
    p.k1 = d.at<double>(0);
    p.k2 = d.at<double>(1);
    p.p1 = d.at<double>(2);
    p.p2 = d.at<double>(3);
    idx = idx.reshape(1, 1);
    for (int i = 0; i < static_cast<int>(idx.total()); ++i)
      result.used_views.push_back(view_of[idx.at<int>(0, i)]);
    std::sort(result.used_views.begin(), result.used_views.end());
  } catch (const cv::Exception& e) {
    result.ok = false;
    result.error = e.what();
    std::replace(result.error.begin(), result.error.end(), '\n', ' ');
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void WriteViewReportImage(const cv::Mat& image, const CalibrationView& view,
                          const std::string& path) {
  cv::Mat canvas;
  if (image.channels() == 1)
    cv::cvtColor(image, canvas, cv::COLOR_GRAY2BGR);
  else
    canvas = image.clone();
  for (size_t i = 0; i < view.corners.size(); ++i) {
    const cv::Point2d detected(view.corners[i].x(), view.corners[i].y());
    cv::circle(canvas, detected, 5, cv::Scalar(0, 255, 0), 1, cv::LINE_AA);
    if (i < view.reprojected.size()) {
      const cv::Point2d reprojected(view.reprojected[i].x(), view.reprojected[i].y());
      cv::drawMarker(canvas, reprojected, cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 8, 1,
                     cv::LINE_AA);
      // Error vector magnified 10x.
      cv::line(canvas, detected, detected + 10.0 * (reprojected - detected),
               cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
    }
  }
  char text[256];
  if (view.board_found)
    std::snprintf(text, sizeof(text),
                  "%s  RMS %.3f px%s  (green: detected, red: reprojected, "
                  "yellow: error x10)",
                  view.name.c_str(), view.rms_px, view.outlier ? "  OUTLIER" : "");
  else
    std::snprintf(text, sizeof(text), "%s  board not found", view.name.c_str());
  cv::putText(canvas, text, cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0),
              3, cv::LINE_AA);
  cv::putText(canvas, text, cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.6,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  WriteImage(path, canvas);
}

}  // namespace oslam
