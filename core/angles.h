// Angle helpers. Angles are radians, wrapped to (-pi, pi].
#pragma once

#include <cmath>

namespace oslam {

constexpr double kPi = 3.14159265358979323846;

inline double WrapAngle(double angle_rad) {
  // Most angles are in range already; std::remainder saves and restores the
  // rounding mode, which made it 4 % of an O-SLAM run.
  if (angle_rad > -kPi && angle_rad <= kPi) return angle_rad;
  double wrapped = std::remainder(angle_rad, 2.0 * kPi);  // in [-pi, pi]
  if (wrapped <= -kPi) wrapped += 2.0 * kPi;
  return wrapped;
}

inline double DegToRad(double deg) { return deg * kPi / 180.0; }
inline double RadToDeg(double rad) { return rad * 180.0 / kPi; }

}  // namespace oslam
