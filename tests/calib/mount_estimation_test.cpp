// The mount (viewpoint height, yaw) from a checkerboard lying on the floor
// at a known place (calib/mount_estimation.h): corners projected by a camera
// with a known mount, with pixel noise, recovered by a camera that starts at
// 1 m and a wrong yaw; for every model of the camera cases.
#include "calib/mount_estimation.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "camera_cases.h"
#include "core/error.h"

namespace oslam {
namespace {

const BoardPattern kPattern{7, 6, 0.06};

// The corners of the board at `place` as `camera` images them, with
// Gaussian pixel noise (seeded); false when a corner has no image.
bool ImageCorners(const CameraModel& camera, const FloorBoardPlace& place, double noise_px,
                  std::uint64_t seed, Corners* corners) {
  std::mt19937_64 engine(seed);
  std::normal_distribution<double> normal(0.0, noise_px);
  corners->clear();
  const double c = std::cos(place.yaw_rad), s = std::sin(place.yaw_rad);
  for (int r = 0; r < kPattern.rows; ++r) {
    for (int k = 0; k < kPattern.cols; ++k) {
      const double u = (k - 0.5 * (kPattern.cols - 1)) * kPattern.square_m;
      const double v = (r - 0.5 * (kPattern.rows - 1)) * kPattern.square_m;
      Eigen::Vector2d pixel;
      if (!camera.ProjectToPixel(
              Eigen::Vector3d(place.x_m + c * u - s * v, place.y_m + s * u + c * v, 0.0), &pixel))
        return false;
      corners->push_back(pixel + Eigen::Vector2d(normal(engine), normal(engine)));
    }
  }
  return true;
}

// Largest pixel distance between where two cameras image a ring of floor
// and wall points around the robot.
double LargestImageDifference(const CameraModel& a, const CameraModel& b) {
  double largest = 0.0;
  for (int k = 0; k < 36; ++k) {
    const double bearing = k * M_PI / 18;
    for (double range : {1.0, 2.0, 4.0}) {
      for (double z : {0.0, 0.5}) {
        const Eigen::Vector3d point(range * std::cos(bearing), range * std::sin(bearing), z);
        Eigen::Vector2d pa, pb;
        if (a.ProjectToPixel(point, &pa) && b.ProjectToPixel(point, &pb))
          largest = std::max(largest, (pa - pb).norm());
      }
    }
  }
  return largest;
}

double FocusHeight(const CameraModel& camera) {
  const std::vector<std::string> names = camera.IntrinsicNames();
  const Eigen::VectorXd values = camera.Intrinsics();
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == "focus_height_m") return values[i];
  return 0.0;
}

TEST(MountEstimation, RecoversHeightAndYawFromAFloorBoard) {
  for (const testing::CameraCase& camera_case : testing::Cameras()) {
    SCOPED_TRACE(camera_case.name);
    const std::unique_ptr<CameraModel> truth = camera_case.make();
    const double true_height = FocusHeight(*truth);
    // The calibration's camera: unmounted (1 m) and turned 0.35 rad off.
    const std::unique_ptr<CameraModel> start = WithMount(*truth, 1.0, -0.35);
    EXPECT_GT(LargestImageDifference(*truth, *start), 20.0);
    const FloorBoardPlace place{1.0, 0.25, 0.2};
    Corners corners;
    ASSERT_TRUE(ImageCorners(*truth, place, 0.3, 7, &corners));
    const MountEstimate estimate = EstimateMountFromFloorBoard(*start, corners, kPattern, place);
    std::printf(
        "%-34s height %.4f m (true %.4f), yaw change %.4f rad (true 0.35), %.1f mm, "
        "%.2f px\n",
        camera_case.name.c_str(), estimate.focus_height_m, true_height, estimate.yaw_change_rad,
        1000 * estimate.floor_rms_m, estimate.image_rms_px);
    // 0.3 px of corner noise: the height within 1 %, the yaw within 0.01 rad,
    // and the re-mounted camera images the room where the true one does.
    EXPECT_NEAR(estimate.focus_height_m, true_height, 0.01 * true_height);
    EXPECT_NEAR(estimate.yaw_change_rad, 0.35, 0.01);
    EXPECT_FALSE(estimate.mirrored);
    EXPECT_LT(estimate.image_rms_px, 1.0);
    EXPECT_EQ(estimate.corners, 42);
    const std::unique_ptr<CameraModel> mounted =
        WithMount(*start, estimate.focus_height_m, estimate.yaw_change_rad);
    EXPECT_LT(LargestImageDifference(*truth, *mounted), 2.0);

    // The detector may read the grid from the other end (and the image is
    // mirrored): the same estimate whatever the corner order.
    const Corners reversed(corners.rbegin(), corners.rend());
    const MountEstimate again = EstimateMountFromFloorBoard(*start, reversed, kPattern, place);
    EXPECT_NEAR(again.focus_height_m, estimate.focus_height_m, 1e-9);
    EXPECT_NEAR(again.yaw_change_rad, estimate.yaw_change_rad, 1e-9);
  }
}

// A hyperbolic camera whose image is mirrored against the truth (what a
// calibration from boards alone may give): the floor board shows it.
TEST(MountEstimation, FindsAnImageMirroredAgainstTheModel) {
  HyperbolicCamera truth = HyperbolicCamera::Preset("lpa");
  HyperbolicMirrorParameters p = truth.parameters();
  p.angle_offset_rad = 0.4;
  truth.set_parameters(p);
  HyperbolicCamera flipped = truth;
  p.flip_image_angle = true;
  p.angle_offset_rad = -1.1;
  p.focus_height_m = 1.0;
  flipped.set_parameters(p);
  const FloorBoardPlace place{1.0, 0.25, 0.2};
  Corners corners;
  ASSERT_TRUE(ImageCorners(truth, place, 0.3, 9, &corners));
  const MountEstimate estimate = EstimateMountFromFloorBoard(flipped, corners, kPattern, place);
  EXPECT_TRUE(estimate.mirrored);
  EXPECT_NEAR(estimate.focus_height_m, 0.76, 0.01 * 0.76);
  EXPECT_LT(estimate.image_rms_px, 1.0);
  const std::unique_ptr<CameraModel> mounted =
      WithMount(flipped, estimate.focus_height_m, estimate.yaw_change_rad, estimate.mirrored);
  EXPECT_LT(LargestImageDifference(truth, *mounted), 2.0);
  // Mei cannot express a mirrored image.
  EXPECT_THROW(WithMount(*testing::Cameras()[3].make(), 1.0, 0.0, true), Error);
}

TEST(MountEstimation, RejectsCornersThatCannotLieOnTheFloor) {
  const std::unique_ptr<CameraModel> camera = testing::Cameras()[0].make();
  Corners corners;
  ASSERT_TRUE(ImageCorners(*camera, {1.0, 0.0, 0.0}, 0.0, 1, &corners));
  corners.pop_back();
  EXPECT_THROW(EstimateMountFromFloorBoard(*camera, corners, kPattern, {1.0, 0.0, 0.0}), Error);
  // A board held above the viewpoint: its rays point up, never to the floor.
  Corners above;
  for (int k = 0; k < 42; ++k) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera->ProjectToPixel(Eigen::Vector3d(2.0, 0.01 * k, 2.0), &pixel));
    above.push_back(pixel);
  }
  EXPECT_THROW(EstimateMountFromFloorBoard(*camera, above, kPattern, {1.0, 0.0, 0.0}), Error);
  EXPECT_THROW(WithMount(*camera, -1.0, 0.0), Error);
}

}  // namespace
}  // namespace oslam
