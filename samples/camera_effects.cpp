#include "samples/camera_effects.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.h"
#include "core/error.h"

namespace oslam {
namespace {

// The image angle (about the image centre) of the direction straight
// behind the robot, on the floor 1 m away.
double ImageAngleBehind(const CameraModel& camera) {
  Eigen::Vector2d pixel;
  if (!camera.ProjectToPixel(Eigen::Vector3d(-1.0, 0.0, 0.0), &pixel)) return M_PI;
  return camera.PixelToPolar(pixel).angle_rad;
}

}  // namespace

CameraEffects::CameraEffects(const CameraModel& camera, const RealismOptions& options,
                             std::mt19937_64& rng)
    : options_(options) {
  const int width = camera.image_width(), height = camera.image_height();
  const Eigen::Vector2d centre = camera.ImageCenter();
  centre_ = cv::Point2f(static_cast<float>(centre.x()), static_cast<float>(centre.y()));
  const MirrorAnnulus& annulus = camera.annulus();
  const double rim =
      annulus.rim_radius_px > 0 ? annulus.rim_radius_px : 0.5 * std::min(width, height);
  const double body_outer =
      annulus.blind_radius_px + options.body_depth * (rim - annulus.blind_radius_px);
  const double behind = ImageAngleBehind(camera);
  usable_.create(height, width, CV_8UC1);
  vignette_.create(height, width, CV_32FC1);
  annulus_.create(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const PolarPoint polar = camera.PixelToPolar(Eigen::Vector2d(x, y));
      const double r = polar.radius_px / rim;
      vignette_.at<float>(y, x) =
          static_cast<float>(std::max(0.0, 1.0 - options.vignetting * r * r));
      annulus_.at<uint8_t>(y, x) = camera.IsInAnnulus(Eigen::Vector2d(x, y)) ? 255 : 0;
      bool rig = polar.radius_px <= body_outer &&
                 std::abs(WrapAngle(polar.angle_rad - behind)) <= 0.5 * options.body_angle_rad;
      for (int k = 0; k < options.rods && !rig; ++k) {
        const double rod_angle = behind + M_PI / options.rods + 2.0 * M_PI * k / options.rods;
        const double off = WrapAngle(polar.angle_rad - rod_angle);
        rig = std::abs(off) < M_PI / 2 &&
              std::abs(polar.radius_px * std::sin(off)) <= 0.5 * options.rod_width_px;
      }
      usable_.at<uint8_t>(y, x) = rig && annulus_.at<uint8_t>(y, x) ? 0 : 255;
    }
  }
  // The rig's look: dark rods, a grey body with a fixed mottled texture.
  rig_colour_.create(height, width, CV_8UC3);
  std::normal_distribution<double> normal(0.0, 1.0);
  cv::Mat texture(height / 4 + 1, width / 4 + 1, CV_32FC1);
  for (int y = 0; y < texture.rows; ++y)
    for (int x = 0; x < texture.cols; ++x)
      texture.at<float>(y, x) = static_cast<float>(12 * normal(rng));
  cv::resize(texture, texture, cv::Size(width, height), 0, 0, cv::INTER_LINEAR);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const PolarPoint polar = camera.PixelToPolar(Eigen::Vector2d(x, y));
      const bool body = polar.radius_px <= body_outer;
      const double base = body ? 95.0 : 45.0;
      const double v = base + texture.at<float>(y, x);
      rig_colour_.at<cv::Vec3b>(y, x) =
          cv::Vec3b(cv::saturate_cast<uchar>(v + 6), cv::saturate_cast<uchar>(v),
                    cv::saturate_cast<uchar>(v - 4));
    }
  }
}

void CameraEffects::Apply(cv::Mat* bgr, double turn_rad, double noise_std, std::mt19937_64& rng) {
  cv::Mat image;
  bgr->convertTo(image, CV_32FC3);
  // Motion blur: the mean of the image turned through the exposure's share
  // of the frame's turn (the rig turns with the camera: drawn after).
  const double blur_deg = RadToDeg(options_.motion_blur * turn_rad);
  if (std::abs(blur_deg) > 0.05) {
    const int steps = 7;
    cv::Mat sum = cv::Mat::zeros(image.size(), image.type()), turned;
    for (int k = 0; k < steps; ++k) {
      const double angle = blur_deg * (k / (steps - 1.0) - 0.5);
      cv::warpAffine(image, turned, cv::getRotationMatrix2D(centre_, angle, 1.0), image.size(),
                     cv::INTER_LINEAR, cv::BORDER_CONSTANT);
      sum += turned;
    }
    image = sum / steps;
  }
  // The rig, with this frame's sensor noise.
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int y = 0; y < image.rows; ++y) {
    const uint8_t* usable = usable_.ptr<uint8_t>(y);
    const cv::Vec3b* rig = rig_colour_.ptr<cv::Vec3b>(y);
    cv::Vec3f* out = image.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.cols; ++x)
      if (!usable[x])
        for (int c = 0; c < 3; ++c)
          out[x][c] = static_cast<float>(rig[x][c] + noise_std * normal(rng));
  }
  image.setTo(cv::Scalar::all(0), annulus_ == 0);
  // Auto-exposure towards the first frame's mean brightness.
  const double mean = cv::mean(image, annulus_)[1];
  if (target_brightness_ < 0) target_brightness_ = mean;
  const double wanted = target_brightness_ / std::max(1.0, mean);
  gain_ *= std::pow(wanted / gain_, options_.auto_exposure_rate) *
           std::exp(options_.exposure_jitter * normal(rng));
  gain_ = std::clamp(gain_, 0.4, 2.5);
  std::vector<cv::Mat> channels;
  cv::split(image, channels);
  for (cv::Mat& channel : channels) channel = channel.mul(vignette_) * gain_;
  cv::merge(channels, image);
  image.convertTo(*bgr, CV_8UC3);
  if (options_.jpeg_quality > 0) {
    std::vector<uchar> bytes;
    cv::imencode(".jpg", *bgr, bytes, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality});
    *bgr = cv::imdecode(bytes, cv::IMREAD_COLOR);
  }
}

}  // namespace oslam
