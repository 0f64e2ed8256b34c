#include "calib/rim_detection.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace oslam {

bool RimDetectionOptions::Validate(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (num_rays < 16) return fail("num_rays must be >= 16");
  if (ransac_iterations < 1) return fail("ransac_iterations must be >= 1");
  if (!(inlier_threshold_px > 0)) return fail("inlier_threshold_px must be positive");
  if (!(blur_sigma_px >= 0)) return fail("blur_sigma_px must be >= 0");
  if (!(min_inlier_fraction > 0 && min_inlier_fraction <= 1))
    return fail("min_inlier_fraction must be in (0, 1]");
  if (!(margin_px >= 0)) return fail("margin_px must be >= 0");
  return true;
}

Circle FitCircle(const std::vector<Eigen::Vector2d>& points) {
  Circle circle;
  if (points.size() < 3) return circle;
  // Algebraic (Kasa): x² + y² + D x + E y + F = 0, around the mean for conditioning.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::MatrixXd a(points.size(), 3);
  Eigen::VectorXd b(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d q = points[i] - mean;
    a.row(i) << q.x(), q.y(), 1.0;
    b[i] = -q.squaredNorm();
  }
  const Eigen::Vector3d s = a.colPivHouseholderQr().solve(b);
  circle.center = mean + Eigen::Vector2d(-s[0] / 2, -s[1] / 2);
  circle.radius = std::sqrt(std::max(0.0, s[0] * s[0] / 4 + s[1] * s[1] / 4 - s[2]));
  // Gauss-Newton on |p - c| - r.
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::MatrixXd j(points.size(), 3);
    Eigen::VectorXd r(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d d = points[i] - circle.center;
      const double n = std::max(d.norm(), 1e-12);
      r[i] = n - circle.radius;
      j.row(i) << -d.x() / n, -d.y() / n, -1.0;
    }
    const Eigen::Vector3d step = (j.transpose() * j).ldlt().solve(-j.transpose() * r);
    if (!step.allFinite()) break;
    circle.center += step.head<2>();
    circle.radius += step[2];
    if (step.norm() < 1e-9) break;
  }
  return circle;
}

namespace {

double Sample(const cv::Mat& image, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= image.cols || y0 + 1 >= image.rows) return NAN;
  const double fx = x - x0, fy = y - y0;
  const float* row0 = image.ptr<float>(y0);
  const float* row1 = image.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * row0[x0] + fx * row0[x0 + 1]) +
         fy * ((1 - fx) * row1[x0] + fx * row1[x0 + 1]);
}

// Strongest step along each ray in [r_min(ray), r_max(ray)]: sign -1 for
// bright-to-dark going outwards, +1 for dark-to-bright. Sub-pixel by a
// parabola through the gradient peak.
std::vector<Eigen::Vector2d> EdgePoints(const cv::Mat& image, const Eigen::Vector2d& centre,
                                        int num_rays, double r_min, double r_max_limit, int sign) {
  std::vector<Eigen::Vector2d> points;
  for (int k = 0; k < num_rays; ++k) {
    const double angle = 2.0 * M_PI * k / num_rays;
    const Eigen::Vector2d direction(std::cos(angle), std::sin(angle));
    std::vector<double> profile;
    for (double r = 0.0; r <= r_max_limit; r += 1.0) {
      const Eigen::Vector2d p = centre + r * direction;
      if (p.x() < 3 || p.y() < 3 || p.x() > image.cols - 4 || p.y() > image.rows - 4) break;
      profile.push_back(Sample(image, p.x(), p.y()));
    }
    const int n = static_cast<int>(profile.size());
    int best = -1;
    double best_value = 0;
    for (int i = std::max(1, static_cast<int>(r_min)); i + 1 < n; ++i) {
      const double gradient = sign * (profile[i + 1] - profile[i - 1]) / 2.0;
      if (gradient > best_value) {
        best_value = gradient;
        best = i;
      }
    }
    if (best < 2 || best + 2 >= n) continue;  // none, or at the border
    const double gm = sign * (profile[best] - profile[best - 2]) / 2.0;
    const double gp = sign * (profile[best + 2] - profile[best]) / 2.0;
    const double denominator = gm - 2.0 * best_value + gp;
    const double offset =
        denominator < 0 ? std::clamp(0.5 * (gm - gp) / denominator, -0.5, 0.5) : 0.0;
    points.push_back(centre + (best + offset) * direction);
  }
  return points;
}

struct RansacFit {
  Circle circle;
  int inliers = 0;
  double rms = 0;
  bool ok = false;
};

RansacFit RansacCircle(const std::vector<Eigen::Vector2d>& points,
                       const RimDetectionOptions& options, std::mt19937_64* engine) {
  RansacFit fit;
  if (points.size() < 3) return fit;
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  std::vector<char> best_mask;
  int best_count = 0;
  for (int iteration = 0; iteration < options.ransac_iterations; ++iteration) {
    const Eigen::Vector2d& a = points[pick(*engine)];
    const Eigen::Vector2d& b = points[pick(*engine)];
    const Eigen::Vector2d& c = points[pick(*engine)];
    // Circumcircle.
    const double d =
        2.0 * (a.x() * (b.y() - c.y()) + b.x() * (c.y() - a.y()) + c.x() * (a.y() - b.y()));
    if (std::abs(d) < 1e-9) continue;
    const double a2 = a.squaredNorm(), b2 = b.squaredNorm(), c2 = c.squaredNorm();
    const Eigen::Vector2d centre(
        (a2 * (b.y() - c.y()) + b2 * (c.y() - a.y()) + c2 * (a.y() - b.y())) / d,
        (a2 * (c.x() - b.x()) + b2 * (a.x() - c.x()) + c2 * (b.x() - a.x())) / d);
    const double radius = (a - centre).norm();
    int count = 0;
    std::vector<char> mask(points.size(), 0);
    for (size_t i = 0; i < points.size(); ++i)
      if (std::abs((points[i] - centre).norm() - radius) < options.inlier_threshold_px) {
        mask[i] = 1;
        ++count;
      }
    if (count > best_count) {
      best_count = count;
      best_mask = mask;
    }
  }
  if (best_count < 3) return fit;
  std::vector<Eigen::Vector2d> inliers;
  for (size_t i = 0; i < points.size(); ++i)
    if (best_mask[i]) inliers.push_back(points[i]);
  fit.circle = FitCircle(inliers);
  // Re-collect inliers around the refined circle once.
  inliers.clear();
  for (const auto& p : points)
    if (std::abs((p - fit.circle.center).norm() - fit.circle.radius) < options.inlier_threshold_px)
      inliers.push_back(p);
  if (inliers.size() >= 3) fit.circle = FitCircle(inliers);
  double sum_sq = 0;
  for (const auto& p : inliers)
    sum_sq += std::pow((p - fit.circle.center).norm() - fit.circle.radius, 2);
  fit.inliers = static_cast<int>(inliers.size());
  fit.rms = inliers.empty() ? 0.0 : std::sqrt(sum_sq / inliers.size());
  fit.ok = true;
  return fit;
}

}  // namespace

RimDetectionResult DetectMirrorRim(const std::vector<cv::Mat>& images,
                                   const RimDetectionOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("rim detection options: " + why);
  RimDetectionResult result;
  if (images.empty()) {
    result.message = "no images";
    return result;
  }
  cv::Mat mean = cv::Mat::zeros(images[0].size(), CV_32F);
  for (const cv::Mat& image : images) {
    if (image.size() != images[0].size()) throw Error("rim detection: images differ in size");
    cv::Mat grey, as_float;
    if (image.channels() == 3)
      cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    else
      grey = image;
    grey.convertTo(as_float, CV_32F);
    mean += as_float;
  }
  mean /= static_cast<double>(images.size());
  if (options.blur_sigma_px > 0) cv::GaussianBlur(mean, mean, cv::Size(), options.blur_sigma_px);

  // Rough centre: centroid of the bright (Otsu) region.
  cv::Mat mean8, bright;
  mean.convertTo(mean8, CV_8U);
  cv::threshold(mean8, bright, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  const cv::Moments moments = cv::moments(bright, true);
  Eigen::Vector2d centre(0.5 * (mean.cols - 1), 0.5 * (mean.rows - 1));
  if (moments.m00 > 0)
    centre = Eigen::Vector2d(moments.m10 / moments.m00, moments.m01 / moments.m00);

  std::mt19937_64 engine(options.seed);
  const double r_max = std::hypot(mean.cols, mean.rows);
  const int min_inliers = static_cast<int>(options.min_inlier_fraction * options.num_rays);
  RansacFit rim;
  for (int pass = 0; pass < 2; ++pass) {
    const double r_min =
        pass == 0 ? 0.15 * std::min(mean.cols, mean.rows) : 0.7 * rim.circle.radius;
    rim = RansacCircle(EdgePoints(mean, centre, options.num_rays, r_min, r_max, -1), options,
                       &engine);
    if (!rim.ok || rim.inliers < min_inliers) {
      result.message = "no circular bright-to-dark mirror rim (" + std::to_string(rim.inliers) +
                       " consistent edge points of " + std::to_string(options.num_rays) + " rays)";
      return result;
    }
    centre = rim.circle.center;
  }
  result.found = true;
  result.rim = rim.circle;
  result.rim_inliers = rim.inliers;
  result.rim_rms_px = rim.rms;
  result.center_px = rim.circle.center;

  // Blind disc: dark-to-bright step well inside the rim.
  const RansacFit blind =
      RansacCircle(EdgePoints(mean, centre, options.num_rays, 3.0, 0.5 * rim.circle.radius, +1),
                   options, &engine);
  result.blind_found = blind.ok && blind.inliers >= min_inliers;
  if (result.blind_found) {
    result.blind = blind.circle;
    result.blind_inliers = blind.inliers;
    result.blind_rms_px = blind.rms;
  }
  const double offset = result.blind_found ? (blind.circle.center - centre).norm() : 0.0;
  const double blind_radius =
      result.blind_found ? blind.circle.radius + offset + options.margin_px : 0.0;
  result.annulus = {blind_radius,
                    std::max(blind_radius + 1.0, rim.circle.radius - options.margin_px)};
  return result;
}

}  // namespace oslam
