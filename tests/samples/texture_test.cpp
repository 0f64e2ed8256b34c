// Surface textures (texture.h): each pattern's layout in surface metres, the
// noise pattern as a pure, continuous, seeded function of (u, v), image tiles
// mapped upright and repeated, and the hash and normal deviates behind the
// sensor noise.
#include "samples/texture.h"

#include <cmath>
#include <cstdint>
#include <memory>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace oslam {
namespace {

const Eigen::Vector3f kLight(0.9f, 0.8f, 0.7f), kDark(0.1f, 0.2f, 0.3f);

Material Patterned(TexturePattern pattern, double scale_m) {
  Material material;
  material.pattern = pattern;
  material.albedo_rgb = kLight;
  material.albedo2_rgb = kDark;
  material.scale_m = scale_m;
  return material;
}

// Where a noise colour lies between the two albedos, by its red channel:
// 0 = the first, 1 = the second.
float NoiseWeight(const Material& material, double u, double v) {
  const Eigen::Vector3f colour = AlbedoAt(material, u, v);
  return (colour.x() - material.albedo_rgb.x()) /
         (material.albedo2_rgb.x() - material.albedo_rgb.x());
}

TEST(Texture, PlainMaterialIsItsAlbedoEverywhere) {
  Material plain;
  plain.albedo_rgb = kLight;
  for (double u : {-3.7, 0.0, 0.05, 12.3})
    for (double v : {-1.0, 0.0, 0.45}) EXPECT_EQ(AlbedoAt(plain, u, v), kLight);
}

TEST(Texture, CheckerSquaresAlternateInBothDirectionsAlsoAcrossZero) {
  const Material checker = Patterned(TexturePattern::kChecker, 0.1);
  EXPECT_EQ(AlbedoAt(checker, 0.05, 0.05), kLight);  // square (0, 0)
  EXPECT_EQ(AlbedoAt(checker, 0.15, 0.05), kDark);
  EXPECT_EQ(AlbedoAt(checker, 0.05, 0.15), kDark);
  EXPECT_EQ(AlbedoAt(checker, 0.15, 0.15), kLight);
  // Squares of side scale_m: every square differs from its four neighbours,
  // including across u = 0 and v = 0 (no doubled square at the origin).
  for (int i = -4; i < 4; ++i)
    for (int j = -4; j < 4; ++j) {
      const Eigen::Vector3f here = AlbedoAt(checker, (i + 0.5) * 0.1, (j + 0.5) * 0.1);
      EXPECT_EQ(here, (i + j) % 2 == 0 ? kLight : kDark) << i << " " << j;
      EXPECT_NE(here, AlbedoAt(checker, (i + 1.5) * 0.1, (j + 0.5) * 0.1)) << i << " " << j;
      EXPECT_NE(here, AlbedoAt(checker, (i + 0.5) * 0.1, (j + 1.5) * 0.1)) << i << " " << j;
      // The whole square has one colour.
      EXPECT_EQ(here, AlbedoAt(checker, (i + 0.02) * 0.1, (j + 0.98) * 0.1));
    }
}

TEST(Texture, StripesRunAlongVAndAlternateAlongU) {
  const Material stripes = Patterned(TexturePattern::kStripes, 0.25);
  for (int i = -4; i < 4; ++i) {
    const Eigen::Vector3f expected = (i % 2 == 0) ? kLight : kDark;
    for (double v : {-7.3, 0.0, 0.1, 5.55})
      EXPECT_EQ(AlbedoAt(stripes, (i + 0.5) * 0.25, v), expected) << i << " " << v;
  }
}

TEST(Texture, NoiseIsAPureFunctionOfPositionAndSeed) {
  Material noise = Patterned(TexturePattern::kNoise, 0.2);
  noise.seed = 11;
  Material other = noise;
  other.seed = 12;
  int differ = 0;
  for (int k = 0; k < 400; ++k) {
    const double u = 0.037 * k - 5.0, v = 0.051 * k - 7.0;
    // The same call gives the same colour, whatever was evaluated in between.
    const Eigen::Vector3f first = AlbedoAt(noise, u, v);
    AlbedoAt(other, u + 1.0, v);
    EXPECT_EQ(AlbedoAt(noise, u, v), first);
    differ += (AlbedoAt(other, u, v) - first).norm() > 0.05f;
  }
  // Another seed is another pattern.
  EXPECT_GT(differ, 200);
}

TEST(Texture, NoiseBlendsTheTwoAlbedosAndReachesBoth) {
  Material noise = Patterned(TexturePattern::kNoise, 0.1);
  noise.seed = 3;
  int at_first = 0, at_second = 0, between = 0;
  double sum = 0, sum_squares = 0;
  const int n = 100 * 100;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) {
      // One sample per noise cell, at varying offsets within it.
      const double u = 0.1 * (i + 0.37 * ((i * 7 + j) % 10) / 10.0);
      const double v = 0.1 * (j + 0.53 * ((i + j * 3) % 10) / 10.0);
      const Eigen::Vector3f colour = AlbedoAt(noise, u, v);
      const float w = NoiseWeight(noise, u, v);
      // On the segment between the albedos: the same weight in every channel.
      const Eigen::Vector3f blend = kLight * (1.0f - w) + kDark * w;
      ASSERT_LT((colour - blend).norm(), 1e-5f) << u << " " << v;
      ASSERT_GE(w, -1e-5f);
      ASSERT_LE(w, 1.0f + 1e-5f);
      at_first += w < 1e-5f;
      at_second += w > 1.0f - 1e-5f;
      between += w > 0.05f && w < 0.95f;
      sum += w;
      sum_squares += w * w;
    }
  // The contrast stretch saturates some of the area at each albedo (crisp
  // blotch edges) and leaves most of it in between; the two are balanced.
  EXPECT_GT(at_first, n / 50);
  EXPECT_GT(at_second, n / 50);
  EXPECT_GT(between, n / 2);
  const double mean = sum / n, spread = std::sqrt(sum_squares / n - mean * mean);
  EXPECT_NEAR(mean, 0.5, 0.05);
  EXPECT_GT(spread, 0.2);
}

TEST(Texture, NoiseIsContinuousAndKeepsItsPhysicalScale) {
  Material noise = Patterned(TexturePattern::kNoise, 0.2);
  noise.seed = 5;
  Material twice = noise;
  twice.scale_m = 0.4;
  for (int k = 0; k < 300; ++k) {
    const double u = 0.0123 * k - 1.5, v = 0.0171 * k - 2.0;
    // A step of a thousandth of a cell moves the colour by little (the
    // blend weight's slope is at most about 6 per cell).
    const float w = NoiseWeight(noise, u, v);
    EXPECT_LT(std::abs(NoiseWeight(noise, u + 2e-4, v) - w), 0.01f) << u << " " << v;
    EXPECT_LT(std::abs(NoiseWeight(noise, u, v + 2e-4) - w), 0.01f) << u << " " << v;
    // Doubling scale_m doubles the pattern: the same colours at twice the distance.
    EXPECT_EQ(AlbedoAt(twice, 2 * u, 2 * v), AlbedoAt(noise, u, v));
  }
  // No jump at the lattice lines, where the cell values change.
  for (int cell = -3; cell <= 3; ++cell) {
    const double line = 0.2 * cell;
    EXPECT_LT(
        std::abs(NoiseWeight(noise, line - 1e-9, 0.13) - NoiseWeight(noise, line + 1e-9, 0.13)),
        1e-4f);
    EXPECT_LT(
        std::abs(NoiseWeight(noise, 0.07, line - 1e-9) - NoiseWeight(noise, 0.07, line + 1e-9)),
        1e-4f);
  }
}

TEST(Texture, ImageTilesAreUprightAndRepeatInBothDirections) {
  // 3 columns x 2 rows, each pixel its own colour: (row, column, 0.5) / 4.
  auto image = std::make_shared<cv::Mat>(2, 3, CV_32FC3);
  for (int row = 0; row < 2; ++row)
    for (int col = 0; col < 3; ++col)
      image->at<cv::Vec3f>(row, col) = cv::Vec3f(row / 4.0f, col / 4.0f, 0.125f);
  Material material;
  material.pattern = TexturePattern::kImage;
  material.image = image;
  material.image_width_m = 0.3;  // 0.1 m per pixel both ways
  material.image_height_m = 0.2;
  for (int tile_u = -2; tile_u <= 2; ++tile_u)
    for (int tile_v = -2; tile_v <= 2; ++tile_v)
      for (int col = 0; col < 3; ++col)
        for (int height = 0; height < 2; ++height) {
          const double u = 0.3 * tile_u + 0.1 * (col + 0.5);
          const double v = 0.2 * tile_v + 0.1 * (height + 0.5);
          // v grows upwards: the lowest 0.1 m of a tile is the image's bottom row.
          const int row = 1 - height;
          EXPECT_EQ(AlbedoAt(material, u, v), Eigen::Vector3f(row / 4.0f, col / 4.0f, 0.125f))
              << "u " << u << " v " << v;
        }
  // A tile's edges belong to the tile: v = 0 is its bottom row, u = 0 its first column.
  EXPECT_EQ(AlbedoAt(material, 0.0, 0.0), Eigen::Vector3f(0.25f, 0.0f, 0.125f));
}

TEST(Texture, MixBitsIsTheSplitMix64Finaliser) {
  // SplitMix64 seeded with 0: its first two outputs.
  EXPECT_EQ(MixBits(0), 0xe220a8397b1dcdafULL);
  EXPECT_EQ(MixBits(0x9e3779b97f4a7c15ULL), 0x6e789e6aa1b965f4ULL);
  // Neighbouring inputs give unrelated outputs: about half the bits flip.
  int flipped = 0;
  for (std::uint64_t x = 0; x < 1000; ++x)
    flipped += __builtin_popcountll(MixBits(x) ^ MixBits(x + 1));
  EXPECT_NEAR(flipped / 1000.0, 32.0, 1.0);
}

TEST(Texture, NormalFromBitsHasUnitVarianceAndBoundedTails) {
  EXPECT_NEAR(NormalFromBits(0), -2.0f * 1.7320508f, 1e-6f);
  EXPECT_NEAR(NormalFromBits(~0ULL), (4.0f * 65535.0f / 65536.0f - 2.0f) * 1.7320508f, 1e-5f);
  double sum = 0, sum_squares = 0, sum_fourth = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double z = NormalFromBits(MixBits(i));
    ASSERT_LE(std::abs(z), 3.4641);
    sum += z;
    sum_squares += z * z;
    sum_fourth += z * z * z * z;
  }
  const double mean = sum / n, variance = sum_squares / n - mean * mean;
  EXPECT_NEAR(mean, 0.0, 0.01);
  EXPECT_NEAR(variance, 1.0, 0.01);
  // Kurtosis of a sum of four uniforms: 3 - 6/20 = 2.7 (a Gaussian's is 3).
  EXPECT_NEAR(sum_fourth / n, 2.7, 0.05);
}

}  // namespace
}  // namespace oslam
