// Classes with a known colour box and images painted with them, shared by
// the colour classifier, colour training and blob detector tests.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/camera_model.h"
#include "core/angles.h"
#include "core/bounding_slice.h"
#include "core/run_folder.h"

namespace oslam::testing {

// BGR colours far apart in YUV.
inline const cv::Vec3b kGreen(60, 170, 40), kPink(180, 105, 255), kBlue(200, 80, 20);

// A class whose colour box is centred on `bgr`, with the same spread in Y, U and V.
inline ObjectClass ClassWithColour(const std::string& name, const cv::Vec3b& bgr,
                                   double noise_std) {
  ObjectClass c;
  c.name = name;
  c.diameter_mean_m = c.height_mean_m = 0.3;
  c.diameter_std_m = c.height_std_m = 0.1;
  cv::Mat pixel(1, 1, CV_8UC3, cv::Scalar(bgr[0], bgr[1], bgr[2])), yuv;
  cv::cvtColor(pixel, yuv, cv::COLOR_BGR2YUV);
  ColourBox box;
  for (int ch = 0; ch < 3; ++ch) {
    box.yuv_mean[ch] = yuv.at<cv::Vec3b>(0, 0)[ch];
    box.yuv_std[ch] = noise_std;
  }
  c.colour = box;
  return c;
}

// Fills the annular sector of `slice` with `colour` (pixel centres inside).
inline void PaintSlice(cv::Mat* image, const CameraModel& camera, const BoundingSlice& slice,
                       const cv::Vec3b& colour) {
  for (int y = 0; y < image->rows; ++y)
    for (int x = 0; x < image->cols; ++x) {
      const PolarPoint p = camera.PixelToPolar({x, y});
      const double dphi = std::abs(WrapAngle(p.angle_rad - slice.u_phi_rad));
      if (p.radius_px >= slice.u_r_px && p.radius_px <= slice.u_r_px + slice.s_r_px &&
          dphi <= 0.5 * slice.s_phi_rad)
        image->at<cv::Vec3b>(y, x) = colour;
    }
}

inline cv::Vec3b ToYuv(const cv::Vec3b& bgr) {
  cv::Mat yuv;
  cv::cvtColor(cv::Mat(1, 1, CV_8UC3, cv::Scalar(bgr[0], bgr[1], bgr[2])), yuv, cv::COLOR_BGR2YUV);
  return yuv.at<cv::Vec3b>(0, 0);
}

// The colour under `factor` times the light: R, G and B scale together.
inline cv::Vec3b Scaled(const cv::Vec3b& bgr, double factor) {
  return cv::Vec3b(cv::saturate_cast<uint8_t>(bgr[0] * factor),
                   cv::saturate_cast<uint8_t>(bgr[1] * factor),
                   cv::saturate_cast<uint8_t>(bgr[2] * factor));
}

}  // namespace oslam::testing
