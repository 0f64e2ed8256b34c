#include "core/bounding_slice.h"

#include <vector>

#include <gtest/gtest.h>

#include "core/angles.h"

namespace oslam {
namespace {

TEST(BoundingSlice, FromExtentsUsesInnerRadiusAndMiddleAngle) {
  const BoundingSlice slice = SliceFromExtents(100, 130, 0.2, 0.6);
  EXPECT_DOUBLE_EQ(slice.u_r_px, 100);
  EXPECT_DOUBLE_EQ(slice.s_r_px, 30);
  EXPECT_NEAR(slice.u_phi_rad, 0.4, 1e-15);
  EXPECT_NEAR(slice.s_phi_rad, 0.4, 1e-15);
}

TEST(BoundingSlice, ArcAcrossThePiSeamHasItsTrueWidth) {
  // From +170 deg counter-clockwise to -170 deg: 20 deg wide, centred on pi.
  const BoundingSlice slice = SliceFromExtents(50, 60, DegToRad(170), DegToRad(-170));
  EXPECT_NEAR(slice.s_phi_rad, DegToRad(20), 1e-12);
  EXPECT_NEAR(std::abs(slice.u_phi_rad), kPi, 1e-12);
}

TEST(BoundingSlice, OfPolarPointsFindsTheSmallestArc) {
  std::vector<double> radii, angles;
  for (double deg = 165; deg <= 195; deg += 1) {  // straddles the seam
    radii.push_back(80 + deg / 10);
    angles.push_back(WrapAngle(DegToRad(deg)));
  }
  const BoundingSlice slice = SliceOfPolarPoints(radii, angles);
  EXPECT_NEAR(slice.s_phi_rad, DegToRad(30), 1e-12);
  EXPECT_NEAR(std::abs(slice.u_phi_rad), kPi, 1e-12);
  EXPECT_NEAR(slice.u_r_px, 80 + 16.5, 1e-12);
  EXPECT_NEAR(slice.s_r_px, 3.0, 1e-12);

  const BoundingSlice plain = SliceOfPolarPoints({10, 20, 15}, {-0.1, 0.3, 0.05});
  EXPECT_NEAR(plain.s_phi_rad, 0.4, 1e-12);
  EXPECT_NEAR(plain.u_phi_rad, 0.1, 1e-12);
  EXPECT_EQ(SliceOfPolarPoints({}, {}).s_phi_rad, 0.0);
}

// A blob all around the image centre (the robot beside a low table) spans
// the full circle and no more, however narrow the gaps between its pixels:
// detections.csv's readers reject s_phi > 2 pi.
TEST(BoundingSlice, PixelCentresAllAroundSpanAtMostTheFullCircle) {
  std::vector<double> radii, angles;
  for (int i = 0; i < 720; ++i) {
    radii.push_back(40.0 + i % 7);
    angles.push_back(-kPi + 2.0 * kPi * i / 720.0);
  }
  const BoundingSlice slice = SliceOfPixelCentres(radii, angles);
  EXPECT_LE(slice.s_phi_rad, 2.0 * kPi);
  EXPECT_GT(slice.s_phi_rad, 2.0 * kPi - 0.01);
  EXPECT_NEAR(slice.u_r_px, 39.5, 1e-12);
  EXPECT_NEAR(slice.s_r_px, 7.0, 1e-12);
}

TEST(BoundingSlice, ElongationIsRadialLengthOverMiddleArcWidth) {
  EXPECT_DOUBLE_EQ(SliceElongation({100.0, 0.3, 20.0, 0.2}), 20.0 / (0.2 * 110.0));
  EXPECT_DOUBLE_EQ(SliceElongation({100.0, 0.3, 20.0, 0.0}), 0.0);
}

TEST(BoundingSlice, CoverageIsTheSharedShareOfTheSlice) {
  const BoundingSlice slice{100.0, 0.0, 20.0, 0.4};
  EXPECT_DOUBLE_EQ(SliceCoverage(slice, slice), 1.0);
  // Half the radial extent and half the arc: a quarter.
  EXPECT_NEAR(SliceCoverage(slice, {110.0, 0.2, 40.0, 0.4}), 0.25, 1e-12);
  // A larger slice covers a smaller one wholly, not the other way round.
  EXPECT_DOUBLE_EQ(SliceCoverage({105.0, 0.0, 5.0, 0.1}, slice), 1.0);
  EXPECT_NEAR(SliceCoverage(slice, {105.0, 0.0, 5.0, 0.1}), 0.25 * 0.25, 1e-12);
  EXPECT_DOUBLE_EQ(SliceCoverage(slice, {130.0, 0.0, 5.0, 0.4}), 0.0);
  EXPECT_DOUBLE_EQ(SliceCoverage(slice, {100.0, 1.0, 20.0, 0.4}), 0.0);
  // Across the ±π seam.
  EXPECT_NEAR(SliceCoverage({100.0, kPi - 0.1, 20.0, 0.4}, {100.0, -kPi + 0.1, 20.0, 0.4}), 0.5,
              1e-12);
  // Two wide arcs meeting on both sides of the circle.
  EXPECT_NEAR(SliceCoverage({100.0, 0.0, 20.0, 4.0}, {100.0, kPi, 20.0, 4.0}),
              2.0 * (4.0 - kPi) / 4.0, 1e-12);
}

}  // namespace
}  // namespace oslam
