#include "calib/mount_estimation.h"

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>

#include "calib/hyperbolic_camera.h"
#include "calib/mei_camera.h"
#include "core/angles.h"
#include "core/error.h"

namespace oslam {
namespace {

// The grid relabellings that map the corner grid onto itself: reading it from
// either end along either axis and, for a square grid, transposed.
std::vector<std::vector<int>> GridSymmetries(const BoardPattern& pattern) {
  std::vector<std::vector<int>> orders;
  const int cols = pattern.cols, rows = pattern.rows;
  for (int transpose = 0; transpose < (cols == rows ? 2 : 1); ++transpose) {
    for (int flip_c = 0; flip_c < 2; ++flip_c) {
      for (int flip_r = 0; flip_r < 2; ++flip_r) {
        std::vector<int> order;
        for (int r = 0; r < rows; ++r) {
          for (int c = 0; c < cols; ++c) {
            int cc = flip_c ? cols - 1 - c : c, rr = flip_r ? rows - 1 - r : r;
            if (transpose) std::swap(cc, rr);
            order.push_back(rr * cols + cc);
          }
        }
        orders.push_back(order);
      }
    }
  }
  return orders;
}

struct Similarity {
  double scale = 0.0, rotation_rad = 0.0, rms = std::numeric_limits<double>::infinity();
};

// argmin over s, ψ of Σ |s R(ψ) u_i − q_i|² in closed form.
Similarity FitScaleRotation(const std::vector<Eigen::Vector2d>& u,
                            const std::vector<Eigen::Vector2d>& q) {
  double dot = 0, cross = 0, norm2 = 0;
  for (size_t i = 0; i < u.size(); ++i) {
    dot += u[i].dot(q[i]);
    cross += u[i].x() * q[i].y() - u[i].y() * q[i].x();
    norm2 += u[i].squaredNorm();
  }
  Similarity fit;
  fit.rotation_rad = std::atan2(cross, dot);
  fit.scale = std::hypot(dot, cross) / norm2;
  const Eigen::Matrix2d rotation = Eigen::Rotation2Dd(fit.rotation_rad).toRotationMatrix();
  double sum = 0;
  for (size_t i = 0; i < u.size(); ++i) sum += (fit.scale * rotation * u[i] - q[i]).squaredNorm();
  fit.rms = std::sqrt(sum / u.size());
  return fit;
}

}  // namespace

MountEstimate EstimateMountFromFloorBoard(const CameraModel& camera, const Corners& corners,
                                          const BoardPattern& pattern,
                                          const FloorBoardPlace& place) {
  const size_t count = static_cast<size_t>(pattern.cols) * pattern.rows;
  if (corners.size() != count || count < 4)
    throw Error("floor board: " + std::to_string(corners.size()) + " corners, the pattern has " +
                std::to_string(count));
  // Corners on the floor as a camera 1 m high sees them.
  std::vector<Eigen::Vector2d> seen;
  for (size_t i = 0; i < count; ++i) {
    Ray ray;
    if (!camera.BackProjectPixel(corners[i], &ray) || !(ray.direction_robot.z() < -1e-6))
      throw Error("floor board: corner " + std::to_string(i) +
                  " is imaged by a ray that does not reach the floor (is the board on the floor, "
                  "below the mirror's horizon?)");
    seen.push_back(ray.direction_robot.head<2>() / -ray.direction_robot.z());
  }
  // Where the corners lie: the grid centred on the place, rows along its yaw.
  const Eigen::Matrix2d turn = Eigen::Rotation2Dd(place.yaw_rad).toRotationMatrix();
  std::vector<Eigen::Vector2d> grid;
  for (int r = 0; r < pattern.rows; ++r)
    for (int c = 0; c < pattern.cols; ++c)
      grid.push_back(Eigen::Vector2d(place.x_m, place.y_m) +
                     turn * Eigen::Vector2d((c - 0.5 * (pattern.cols - 1)) * pattern.square_m,
                                            (r - 0.5 * (pattern.rows - 1)) * pattern.square_m));
  std::vector<Eigen::Vector2d> reflected = seen;
  for (Eigen::Vector2d& u : reflected) u.y() = -u.y();
  Similarity best;
  bool best_mirrored = false;
  std::vector<Eigen::Vector2d> best_lying;
  for (const std::vector<int>& order : GridSymmetries(pattern)) {
    std::vector<Eigen::Vector2d> lying(count);
    for (size_t i = 0; i < count; ++i) lying[i] = grid[order[i]];
    for (const bool mirrored : {false, true}) {
      const Similarity fit = FitScaleRotation(mirrored ? reflected : seen, lying);
      if (fit.rms < best.rms) {
        best = fit;
        best_mirrored = mirrored;
        best_lying = lying;
      }
    }
  }
  MountEstimate estimate;
  estimate.mirrored = best_mirrored;
  estimate.focus_height_m = best.scale;
  estimate.yaw_change_rad = WrapAngle(best.rotation_rad);
  estimate.floor_rms_m = best.rms;
  estimate.corners = static_cast<int>(count);
  const std::unique_ptr<CameraModel> mounted =
      WithMount(camera, estimate.focus_height_m, estimate.yaw_change_rad, estimate.mirrored);
  double sum = 0;
  for (size_t i = 0; i < count; ++i) {
    Eigen::Vector2d pixel;
    if (!mounted->ProjectToPixel(Eigen::Vector3d(best_lying[i].x(), best_lying[i].y(), 0.0),
                                 &pixel))
      throw Error("floor board: the estimated mount does not image corner " + std::to_string(i));
    sum += (pixel - corners[i]).squaredNorm();
  }
  estimate.image_rms_px = std::sqrt(sum / count);
  return estimate;
}

std::unique_ptr<CameraModel> WithMount(const CameraModel& camera, double focus_height_m,
                                       double yaw_change_rad, bool mirrored) {
  if (!(focus_height_m > 0) || !std::isfinite(focus_height_m) || !std::isfinite(yaw_change_rad))
    throw Error("mount: the height must be positive and the yaw finite");
  std::unique_ptr<CameraModel> mounted = camera.Clone();
  if (auto* mei = dynamic_cast<MeiCamera*>(mounted.get())) {
    if (mirrored)
      throw Error(
          "mount: the floor board shows the image mirrored against the Mei model, which cannot "
          "express it; calibrate with --model hyperbolic");
    MeiParameters p = mei->parameters();
    p.focus_height_m = focus_height_m;
    p.mount_yaw_rad = WrapAngle(p.mount_yaw_rad + yaw_change_rad);
    mei->set_parameters(p);
  } else if (auto* hyperbolic = dynamic_cast<HyperbolicCamera*>(mounted.get())) {
    // Image angle = offset + s · bearing: the turned camera sees bearing b
    // as the unturned one saw b − Δ, so offset' = offset − s Δ.
    // Mirrored: the true bearing is Δ − b for the model's b, so the sign
    // flips and offset' = offset + s Δ (s the old sign).
    HyperbolicMirrorParameters p = hyperbolic->parameters();
    p.focus_height_m = focus_height_m;
    const double sign = p.flip_image_angle ? -1.0 : 1.0;
    if (mirrored) {
      p.flip_image_angle = !p.flip_image_angle;
      p.angle_offset_rad = WrapAngle(p.angle_offset_rad + sign * yaw_change_rad);
    } else {
      p.angle_offset_rad = WrapAngle(p.angle_offset_rad - sign * yaw_change_rad);
    }
    hyperbolic->set_parameters(p);
  } else {
    throw Error("mount: the " + camera.ModelName() + " model has no mount to set");
  }
  return mounted;
}

}  // namespace oslam
