#include "core/bounding_slice.h"

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

}  // namespace
}  // namespace oslam
