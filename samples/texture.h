// Surface colour of a material at texture coordinates (u, v), in metres on
// the surface. Procedural patterns are pure functions of (u, v, seed), so
// frames are reproducible and patterns stay put on the object as the robot
// moves (which is what lets SIFT match features between frames).
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "samples/scene.h"

namespace oslam {

Eigen::Vector3f AlbedoAt(const Material& material, double u, double v);

// A well-mixed 64-bit hash (splitmix64 finaliser): the one source of
// per-pixel randomness, so results do not depend on evaluation order.
inline std::uint64_t MixBits(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Approximately standard normal from one hash (sum of four 16-bit uniforms,
// rescaled to unit variance; bounded at +-3.46 sigma, fine for sensor noise).
inline float NormalFromBits(std::uint64_t bits) {
  const float sum = static_cast<float>((bits & 0xffff) + ((bits >> 16) & 0xffff) +
                                       ((bits >> 32) & 0xffff) + (bits >> 48));
  return (sum / 65536.0f - 2.0f) * 1.7320508f;
}

}  // namespace oslam
