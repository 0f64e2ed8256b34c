#include "samples/texture.h"

#include <algorithm>
#include <cmath>

namespace oslam {

namespace {

// Lattice value in [0, 1) for cell (ix, iy).
float LatticeValue(long ix, long iy, std::uint64_t seed) {
  const std::uint64_t h = MixBits(seed ^ MixBits(static_cast<std::uint64_t>(ix) * 0x9E3779B1ULL ^
                                                 MixBits(static_cast<std::uint64_t>(iy))));
  return static_cast<float>(h >> 40) / static_cast<float>(1 << 24);
}

// Smoothly interpolated value noise with cells of size 1.
float ValueNoise(double u, double v, std::uint64_t seed) {
  const double fu = std::floor(u), fv = std::floor(v);
  const long iu = static_cast<long>(fu), iv = static_cast<long>(fv);
  auto smooth = [](double t) { return static_cast<float>(t * t * (3.0 - 2.0 * t)); };
  const float su = smooth(u - fu), sv = smooth(v - fv);
  const float a = LatticeValue(iu, iv, seed), b = LatticeValue(iu + 1, iv, seed);
  const float c = LatticeValue(iu, iv + 1, seed), d = LatticeValue(iu + 1, iv + 1, seed);
  return (a + (b - a) * su) * (1 - sv) + (c + (d - c) * su) * sv;
}

// Two octaves, contrast-stretched: blotches with crisp enough edges for
// corner and blob detectors.
float BlotchPattern(double u, double v, std::uint64_t seed) {
  const float n = 0.65f * ValueNoise(u, v, seed) + 0.35f * ValueNoise(2.0 * u, 2.0 * v, seed + 7);
  return std::clamp((n - 0.5f) * 3.0f + 0.5f, 0.0f, 1.0f);
}

Eigen::Vector3f ImageAt(const Material& material, double u, double v) {
  const cv::Mat& image = *material.image;
  auto wrap01 = [](double x) { return x - std::floor(x); };
  const int col =
      std::min(image.cols - 1, static_cast<int>(wrap01(u / material.image_width_m) * image.cols));
  // v grows upwards on the surface, image rows grow downwards.
  const int row = std::min(
      image.rows - 1, static_cast<int>((1.0 - wrap01(v / material.image_height_m)) * image.rows));
  const cv::Vec3f& rgb = image.at<cv::Vec3f>(row, col);
  return {rgb[0], rgb[1], rgb[2]};
}

}  // namespace

Eigen::Vector3f AlbedoAt(const Material& material, double u, double v) {
  const double s = material.scale_m;
  switch (material.pattern) {
    case TexturePattern::kNone:
      return material.albedo_rgb;
    case TexturePattern::kChecker: {
      const long k = static_cast<long>(std::floor(u / s)) + static_cast<long>(std::floor(v / s));
      return (k & 1) ? material.albedo2_rgb : material.albedo_rgb;
    }
    case TexturePattern::kStripes:
      return (static_cast<long>(std::floor(u / s)) & 1) ? material.albedo2_rgb
                                                        : material.albedo_rgb;
    case TexturePattern::kNoise: {
      const float w = BlotchPattern(u / s, v / s, material.seed);
      return material.albedo_rgb * (1.0f - w) + material.albedo2_rgb * w;
    }
    case TexturePattern::kImage:
      return ImageAt(material, u, v);
  }
  return material.albedo_rgb;
}

}  // namespace oslam
