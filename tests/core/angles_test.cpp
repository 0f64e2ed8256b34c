#include "core/angles.h"

#include <gtest/gtest.h>

namespace oslam {
namespace {

TEST(WrapAngle, MapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(WrapAngle(0.0), 0.0);
  EXPECT_DOUBLE_EQ(WrapAngle(kPi), kPi);
  EXPECT_DOUBLE_EQ(WrapAngle(-kPi), kPi);  // (-pi, pi]
  EXPECT_NEAR(WrapAngle(3 * kPi / 2), -kPi / 2, 1e-15);
  EXPECT_NEAR(WrapAngle(-7.0), -7.0 + 2 * kPi, 1e-15);
  EXPECT_NEAR(WrapAngle(1000.0), std::remainder(1000.0, 2 * kPi), 1e-12);
  for (double angle = -20; angle < 20; angle += 0.137) {
    const double wrapped = WrapAngle(angle);
    EXPECT_GT(wrapped, -kPi);
    EXPECT_LE(wrapped, kPi);
    EXPECT_NEAR(std::cos(wrapped), std::cos(angle), 1e-12);
    EXPECT_NEAR(std::sin(wrapped), std::sin(angle), 1e-12);
  }
}

TEST(Degrees, RoundTrip) {
  EXPECT_DOUBLE_EQ(DegToRad(180.0), kPi);
  EXPECT_DOUBLE_EQ(RadToDeg(DegToRad(10.0)), 10.0);
}

}  // namespace
}  // namespace oslam
