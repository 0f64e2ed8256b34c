// Observation model h_u, h_s (docs/method.md §4.2) against the docs/method.md §4.3 full
// observation vectors and central differences.
#include "calib/observation_model.h"

#include <gtest/gtest.h>

#include "calib/hyperbolic_camera.h"
#include "core/angles.h"
#include "test_util.h"

namespace oslam {
namespace {

struct ObservationVector {
  const char* preset;
  Pose2 pose;
  Eigen::Vector3d base;
  double diameter, height;
  BoundingSlice expected;
};

class SpecObservationVectors : public ::testing::TestWithParam<ObservationVector> {};

// Given to 3 (pixels) / 5 (radians) decimals in the spec.
TEST_P(SpecObservationVectors, MatchToSpecPrecision) {
  const ObservationVector v = GetParam();
  const HyperbolicCamera camera = HyperbolicCamera::Preset(v.preset);
  BoundingSlice slice;
  ASSERT_TRUE(PredictSlice(camera, v.pose, {v.base, v.diameter, v.height}, &slice));
  EXPECT_NEAR(slice.u_r_px, v.expected.u_r_px, 1e-3);
  EXPECT_NEAR(slice.u_phi_rad, v.expected.u_phi_rad, 1e-5);
  EXPECT_NEAR(slice.s_r_px, v.expected.s_r_px, 1e-3);
  EXPECT_NEAR(slice.s_phi_rad, v.expected.s_phi_rad, 1e-5);
}

INSTANTIATE_TEST_SUITE_P(
    Spec, SpecObservationVectors,
    ::testing::Values(
        ObservationVector{"lpa", {0, 0, 0}, {2, 1, 0}, 0.6, 0.6, {144.000, 0.46365, 43.369, 0.26674}},
        ObservationVector{
            "lpa", {1, -1, kPi / 2}, {1.5, 2, 0}, 0.25, 0.25, {157.026, -0.16515, 13.210, 0.08215}},
        ObservationVector{
            "cogniron", {0, 0, 0}, {3, 0, 0}, 1.8, 1.2, {184.488, 0.00000, 89.758, 0.58291}},
        ObservationVector{"cogniron",
                          {0.5, 0.5, 0.3},
                          {-1, 2, 0},
                          1.0,
                          1.7,
                          {161.124, 2.05619, 192.642, 0.46295}}),
    [](const auto& info) { return std::string(info.param.preset) + "_" + std::to_string(info.index); });

Eigen::VectorXd SliceVector(const CameraModel& camera, const Eigen::VectorXd& x) {
  // x = pose (3), base (3), size (2)
  BoundingSlice slice;
  const Pose2 pose{x[0], x[1], x[2]};
  EXPECT_TRUE(PredictSlice(camera, pose, {x.segment<3>(3), x[6], x[7]}, &slice));
  return Eigen::Vector4d(slice.u_r_px, slice.u_phi_rad, slice.s_r_px, slice.s_phi_rad);
}

TEST(ObservationModel, JacobiansMatchCentralDifferences) {
  HyperbolicCamera flipped = HyperbolicCamera::Preset("lpa");
  HyperbolicMirrorParameters p = flipped.parameters();
  p.flip_image_angle = true;
  p.angle_offset_rad = -1.1;
  flipped.set_parameters(p);
  const HyperbolicCamera cameras[] = {HyperbolicCamera::Preset("lpa"),
                                      HyperbolicCamera::Preset("cogniron"), flipped};
  const std::vector<Eigen::Matrix<double, 8, 1>> cases = [] {
    std::vector<Eigen::Matrix<double, 8, 1>> c(4);
    c[0] << 0, 0, 0, 2, 1, 0, 0.6, 0.6;
    c[1] << 1, -1, kPi / 2, 1.5, 2, 0, 0.25, 0.25;
    c[2] << 0.5, 0.5, 0.3, -1, 2, 0.2, 1.0, 1.7;
    c[3] << -2, 3, -2.5, 1, -1, 0.05, 0.3, 0.4;
    return c;
  }();
  for (const HyperbolicCamera& camera : cameras) {
    for (const auto& x : cases) {
      BoundingSlice slice;
      SliceJacobians analytic;
      ASSERT_TRUE(PredictSlice(camera, {x[0], x[1], x[2]}, {x.segment<3>(3), x[6], x[7]}, &slice,
                               &analytic));
      const Eigen::MatrixXd numeric = testing::NumericJacobian(
          [&](const Eigen::VectorXd& v) { return SliceVector(camera, v); }, x);
      Eigen::Matrix<double, 4, 8> combined;
      combined << analytic.wrt_pose, analytic.wrt_base, analytic.wrt_size;
      for (int row = 0; row < 4; ++row) {
        for (int col = 0; col < 8; ++col) {
          EXPECT_NEAR(combined(row, col), numeric(row, col),
                      1e-6 * std::max(1.0, std::abs(numeric(row, col))))
              << "row " << row << " col " << col << " case " << x.transpose();
        }
      }
    }
  }
}

TEST(ObservationModel, ObjectOnTheCameraAxisHasNoSlice) {
  BoundingSlice slice;
  EXPECT_FALSE(PredictSlice(HyperbolicCamera::Preset("lpa"), {1, 1, 0},
                            {Eigen::Vector3d(1, 1, 0), 0.3, 0.3}, &slice));
}

}  // namespace
}  // namespace oslam
