// Physical bounds on every value oslam reads (docs/formats.md, "Bounds").
// A value outside them is an input error, reported where it was read. They
// keep each size, loop and allocation that an input value drives bounded: a
// finite but absurd number (a coordinate of 1e300 m, a 60000-pixel-wide
// camera) fails at once instead of running for hours or exhausting memory.
// The one place these numbers live; readers and option checks use them.
#pragma once

#include <string>

namespace oslam {
namespace bounds {

// Positions in metres (world and robot frames: poses, object base points,
// landmarks, GPS fixes, scene objects): |x|, |y|, |z| at most this.
inline constexpr double kCoordinateM = 1e5;
// Standard deviations of sizes and positions (priors, noise), m: at least
// a micron. The solver weighs by their inverse squares; below this the
// weights overflow and a prior stops being a proper one.
inline constexpr double kMinStdM = 1e-6;
// Speeds of the robot (m/s), as odometry inputs give them.
inline constexpr double kSpeedMps = 1000.0;
// Object sizes in metres (diameters, heights, box extents, size priors).
inline constexpr double kObjectSizeM = 100.0;
// Angles read as headings, bearings, turns, yaws and slice angles (radians):
// |angle| at most this (a few turns: values are wrapped, never looped over).
inline constexpr double kAngleRad = 100.0;
// Images (frames, camera.yaml's image size, figures, the simulator's
// renders): each side and the pixel count at most these.
inline constexpr int kImageSidePx = 16384;
inline constexpr long kImagePixels = 40'000'000;
// Figures drawn (bird's-eye, perspective, trajectories): side at most.
inline constexpr int kFigureSidePx = 8192;
// Radii in an image (slice radii and radial lengths, the mirror annulus):
// twice the largest side, so any point of any image fits.
inline constexpr double kImageRadiusPx = 2.0 * kImageSidePx;
// Frames of a run, frame numbers and pose counts.
inline constexpr long kFrames = 10'000'000;
// Ids (objects, landmarks, tracks) fit an int with room to spare.
inline constexpr long kId = 1'000'000'000;
// Input files are read whole; larger files are refused before reading.
inline constexpr long kFileBytes = 1L << 30;

// "VALUE is outside [LOW, HIGH]UNIT (docs/formats.md, Bounds)" for messages.
std::string OutsideMessage(double value, double low, double high, const std::string& unit = "");

// "the odometry reaches (X, Y) m at WHERE, beyond the position bound of
// +-100000 m (docs/formats.md, Bounds)": integrated odometry gone too far.
std::string ReachMessage(double x_m, double y_m, const std::string& where);

// True when value lies in [low, high] (false for NaN).
inline bool Within(double value, double low, double high) {
  return value >= low && value <= high;
}

}  // namespace bounds
}  // namespace oslam
