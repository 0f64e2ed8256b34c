// Image centre and mirror annulus from ordinary frames: the outer mirror rim
// and the central blind disc (the camera's own reflection) are circles that
// stay put while the scene moves.
//
//   1. mean of the frames, Gaussian blur (scene texture averages out);
//   2. along rays from a rough centre (centroid of the Otsu-bright region),
//      the strongest bright-to-dark step (rim) and, inside the rim, the
//      strongest dark-to-bright step (blind disc edge);
//   3. RANSAC circle fit (3-point circles, seeded) on each edge set, then a
//      least-squares refit on the inliers; steps 2-3 are repeated once around
//      the fitted centre.
// Edge points within 3 px of the image border are ignored (a rim cut by the
// border still fits on its visible part).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/camera_model.h"

namespace oslam {

struct RimDetectionOptions {
  int num_rays = 720;
  int ransac_iterations = 1000;
  double inlier_threshold_px = 1.5;
  double blur_sigma_px = 1.5;
  double min_inlier_fraction = 0.25;  // of the rays, per circle
  double margin_px = 2.0;             // annulus shrunk by this on both sides
  std::uint64_t seed = 1;
  bool Validate(std::string* why) const;
};

struct Circle {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0.0;
};

struct RimDetectionResult {
  bool found = false;   // the rim was found (the blind disc is optional)
  std::string message;  // why not, when !found
  Eigen::Vector2d center_px = Eigen::Vector2d::Zero();  // rim circle centre
  Circle rim, blind;
  bool blind_found = false;
  int rim_inliers = 0, blind_inliers = 0;
  double rim_rms_px = 0.0, blind_rms_px = 0.0;
  MirrorAnnulus annulus;  // around center_px
};

// Least-squares circle (algebraic fit refined by Gauss-Newton on the
// geometric distance). Needs >= 3 points.
Circle FitCircle(const std::vector<Eigen::Vector2d>& points);

// `images`: 8-bit grey or BGR frames of the same size (at least one).
RimDetectionResult DetectMirrorRim(const std::vector<cv::Mat>& images,
                                   const RimDetectionOptions& options = {});

}  // namespace oslam
