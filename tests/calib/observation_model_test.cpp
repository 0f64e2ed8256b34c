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
        ObservationVector{
            "lpa", {0, 0, 0}, {2, 1, 0}, 0.6, 0.6, {144.000, 0.46365, 43.369, 0.26674}},
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
    [](const auto& info) {
      return std::string(info.param.preset) + "_" + std::to_string(info.index);
    });

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

Eigen::VectorXd SilhouetteVector(const CameraModel& camera, const SilhouetteModel& model,
                                 const Eigen::VectorXd& x) {
  BoundingSlice slice;
  EXPECT_TRUE(PredictSlice(camera, {x[0], x[1], x[2]}, {x.segment<3>(3), x[6], x[7]}, &slice,
                           nullptr, model));
  return Eigen::Vector4d(slice.u_r_px, slice.u_phi_rad, slice.s_r_px, slice.s_phi_rad);
}

TEST(SilhouetteModel, JacobiansMatchCentralDifferences) {
  const HyperbolicCamera cameras[] = {HyperbolicCamera::Preset("lpa"),
                                      HyperbolicCamera::Preset("cogniron")};
  // Objects below the viewpoint and a door above it (its top's near edge is outermost).
  std::vector<Eigen::Matrix<double, 8, 1>> cases(4);
  cases[0] << 0, 0, 0, 2, 1, 0, 0.6, 0.6;
  cases[1] << 1, -1, kPi / 2, 1.5, 2, 0, 0.25, 0.25;
  cases[2] << 0.5, 0.5, 0.3, -1, 2, 0.02, 1.0, 2.1;
  cases[3] << -2, 3, -2.5, 1, -1, 0.05, 0.3, 0.4;
  for (const ObjectShape shape :
       {ObjectShape::kCylinder, ObjectShape::kBox, ObjectShape::kSphere, ObjectShape::kPanel}) {
    const SilhouetteModel model = SilhouetteOf(cameras[0], shape, 0.6);
    for (const HyperbolicCamera& camera : cameras) {
      for (const auto& x : cases) {
        BoundingSlice slice;
        SliceJacobians analytic;
        ASSERT_TRUE(PredictSlice(camera, {x[0], x[1], x[2]}, {x.segment<3>(3), x[6], x[7]}, &slice,
                                 &analytic, model));
        const Eigen::MatrixXd numeric = testing::NumericJacobian(
            [&](const Eigen::VectorXd& v) { return SilhouetteVector(camera, model, v); }, x);
        Eigen::Matrix<double, 4, 8> combined;
        combined << analytic.wrt_pose, analytic.wrt_base, analytic.wrt_size;
        EXPECT_LT((combined - numeric).cwiseAbs().maxCoeff(),
                  1e-6 * std::max(1.0, numeric.cwiseAbs().maxCoeff()))
            << ObjectShapeName(shape) << " case " << x.transpose();
      }
    }
  }
}

// The silhouette's ends are the image radii of the footprint's near edge at
// the base and of the top's far edge (below the viewpoint) or near edge
// (above it), and its width is the cylinder's.
TEST(SilhouetteModel, EndsAreTheFootprintEdges) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const SilhouetteModel cylinder = SilhouetteOf(camera, ObjectShape::kCylinder);
  for (const double height : {0.5, 2.0}) {  // the LPA viewpoint is at 0.76 m
    BoundingSlice section, silhouette;
    const CylinderGeometry object{Eigen::Vector3d(2, 0, 0), 0.4, height};
    ASSERT_TRUE(PredictSlice(camera, {}, object, &section));
    ASSERT_TRUE(PredictSlice(camera, {}, object, &silhouette, nullptr, cylinder));
    double near_base, top;
    ASSERT_TRUE(camera.ProjectRadius({1.8, 0, 0}, &near_base));
    ASSERT_TRUE(camera.ProjectRadius({height < 0.76 ? 2.2 : 1.8, 0, height}, &top));
    EXPECT_NEAR(silhouette.u_r_px, near_base, 1e-9);
    EXPECT_NEAR(silhouette.u_r_px + silhouette.s_r_px, top, 1e-9);
    EXPECT_LT(silhouette.u_r_px, section.u_r_px - 2.0);  // the near edge is well inside
    EXPECT_GT(silhouette.s_r_px, section.s_r_px);        // and the top face adds length
    EXPECT_NEAR(silhouette.s_phi_rad, section.s_phi_rad, 1e-12);
  }
}

// A ball's outline against brute force: the smallest and largest image radius
// over points on its surface.
TEST(SilhouetteModel, SphereEndsMatchItsSurface) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const SilhouetteModel sphere = SilhouetteOf(camera, ObjectShape::kSphere);
  for (const double diameter : {0.2, 0.5}) {
    for (double range = 0.8; range <= 4.0; range += 0.8) {
      BoundingSlice slice;
      const Eigen::Vector3d base(range, 0.3, 0.0);
      ASSERT_TRUE(PredictSlice(camera, {}, {base, diameter, diameter}, &slice, nullptr, sphere));
      double low = 1e9, high = 0;
      const Eigen::Vector3d centre = base + Eigen::Vector3d(0, 0, diameter / 2);
      for (int i = 0; i <= 400; ++i) {
        const double polar = kPi * i / 400;
        for (int j = 0; j < 400; ++j) {
          const double azimuth = 2 * kPi * j / 400;
          const Eigen::Vector3d point =
              centre + diameter / 2 *
                           Eigen::Vector3d(std::sin(polar) * std::cos(azimuth),
                                           std::sin(polar) * std::sin(azimuth), std::cos(polar));
          double radius;
          if (!camera.ProjectRadius(point, &radius)) continue;
          low = std::min(low, radius);
          high = std::max(high, radius);
        }
      }
      EXPECT_NEAR(slice.u_r_px, low, 0.05) << "range " << range;
      EXPECT_NEAR(slice.u_r_px + slice.s_r_px, high, 0.05) << "range " << range;
    }
  }
}

TEST(SilhouetteModel, BoxAndPanelExtentsAreMeansOverYaw) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  // A square box: the mean half extent of a square of diagonal 1 over yaw, 2/(pi sqrt 2).
  EXPECT_NEAR(SilhouetteOf(camera, ObjectShape::kBox, 1.0).width_half_extent, 0.450158, 1e-6);
  // By quadrature over yaw for a 0.23 x 0.14 box (aspect 0.61).
  const double length = 0.23, width = 0.14, diagonal = std::hypot(length, width);
  double mean = 0;
  const int steps = 100000;
  for (int i = 0; i < steps; ++i) {
    const double yaw = (i + 0.5) * kPi / steps;
    mean += 0.5 * (length * std::abs(std::cos(yaw)) + width * std::abs(std::sin(yaw))) / steps;
  }
  EXPECT_NEAR(SilhouetteOf(camera, ObjectShape::kBox, width / length).depth_half_extent,
              mean / diagonal, 1e-6);
  EXPECT_NEAR(SilhouetteOf(camera, ObjectShape::kPanel).width_half_extent, 1 / kPi, 1e-12);
  EXPECT_NEAR(SilhouetteOf(camera, ObjectShape::kSphere).viewpoint_height_m,
              camera.parameters().focus_height_m, 1e-9);
}

// A panel's slice as a function of (pose, base, diameter, height, yaw).
Eigen::VectorXd PanelVector(const CameraModel& camera, const SilhouetteModel& model,
                            const Eigen::VectorXd& x) {
  BoundingSlice slice;
  CylinderGeometry panel{x.segment<3>(3), x[6], x[7]};
  panel.yaw_rad = x[8];
  EXPECT_TRUE(PredictSlice(camera, {x[0], x[1], x[2]}, panel, &slice, nullptr, model));
  return Eigen::Vector4d(slice.u_r_px, slice.u_phi_rad, slice.s_r_px, slice.s_phi_rad);
}

// The panel's orientation enters through alpha = yaw - bearing: every block,
// the yaw's included, against central differences, face-on, oblique and
// nearly edge-on, below and above the viewpoint.
TEST(SilhouetteModel, PanelJacobiansWithYawMatchCentralDifferences) {
  const HyperbolicCamera cameras[] = {HyperbolicCamera::Preset("lpa"),
                                      HyperbolicCamera::Preset("cogniron")};
  const SilhouetteModel model = SilhouetteOf(cameras[0], ObjectShape::kPanel);
  ASSERT_TRUE(model.panel);
  std::vector<Eigen::Matrix<double, 9, 1>> cases;
  for (const double yaw : {0.0, 0.4, kPi / 2 - 0.01, 1.2, -2.0, 2.9}) {
    Eigen::Matrix<double, 9, 1> x;
    x << 0.5, 0.5, 0.3, -1, 2, 0.02, 1.0, 2.1, yaw;  // a door, its top above the viewpoint
    cases.push_back(x);
    x << 0, 0, 0, 3, 1, 0, 1.2, 0.5, yaw;  // a low panel
    cases.push_back(x);
  }
  for (const HyperbolicCamera& camera : cameras) {
    for (const auto& x : cases) {
      BoundingSlice slice;
      SliceJacobians analytic;
      CylinderGeometry panel{x.segment<3>(3), x[6], x[7]};
      panel.yaw_rad = x[8];
      ASSERT_TRUE(PredictSlice(camera, {x[0], x[1], x[2]}, panel, &slice, &analytic, model));
      const Eigen::MatrixXd numeric = testing::NumericJacobian(
          [&](const Eigen::VectorXd& v) { return PanelVector(camera, model, v); }, x);
      Eigen::Matrix<double, 4, 9> combined;
      combined << analytic.wrt_pose, analytic.wrt_base, analytic.wrt_size, analytic.wrt_yaw;
      EXPECT_LT((combined - numeric).cwiseAbs().maxCoeff(),
                1e-6 * std::max(1.0, numeric.cwiseAbs().maxCoeff()))
          << "case " << x.transpose();
    }
  }
}

// A panel's angular width is what its two vertical edges subtend: the full
// width face-on, none edge-on, and in between the edges' bearings (exact up
// to the second order in width / range). Turned by pi it is the same panel.
TEST(SilhouetteModel, PanelWidthFollowsItsOrientation) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const SilhouetteModel model = SilhouetteOf(camera, ObjectShape::kPanel);
  const double width = 1.04, range = 3.0;
  for (double alpha = 0.0; alpha < kPi; alpha += kPi / 12) {
    // The panel at (range, 0), its length turned by alpha from the line of sight.
    CylinderGeometry panel{Eigen::Vector3d(range, 0, 0), width, 2.17};
    panel.yaw_rad = alpha;
    BoundingSlice slice, turned;
    ASSERT_TRUE(PredictSlice(camera, {}, panel, &slice, nullptr, model));
    panel.yaw_rad = alpha + kPi;
    ASSERT_TRUE(PredictSlice(camera, {}, panel, &turned, nullptr, model));
    EXPECT_NEAR(turned.s_phi_rad, slice.s_phi_rad, 1e-12);
    const Eigen::Vector2d edge = 0.5 * width * Eigen::Vector2d(std::cos(alpha), std::sin(alpha));
    const double subtended =
        std::abs(std::atan2(edge.y(), range + edge.x()) - std::atan2(-edge.y(), range - edge.x()));
    EXPECT_NEAR(slice.s_phi_rad, subtended, 0.02 * 2 * std::atan(0.5 * width / range) + 0.01)
        << "alpha " << alpha;
  }
  CylinderGeometry face_on{Eigen::Vector3d(range, 0, 0), width, 2.17};
  face_on.yaw_rad = kPi / 2;
  BoundingSlice slice;
  ASSERT_TRUE(PredictSlice(camera, {}, face_on, &slice, nullptr, model));
  EXPECT_NEAR(slice.s_phi_rad, 2 * std::atan(0.5 * width / range), 1e-3);
}

TEST(SliceCensoring, EndsAtTheImageLimitsAreBounds) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const MirrorAnnulus annulus = camera.annulus();
  ASSERT_GT(annulus.rim_radius_px, 0);
  // Pointing along the image's long side (angle 0: +x), away from its border.
  BoundingSlice inside{120, 0.0, 40, 0.2};
  SliceCensoring c = CensoringOf(camera, inside, 2.0);
  EXPECT_FALSE(c.inner);
  EXPECT_FALSE(c.outer);
  BoundingSlice at_rim{150, 0.0, annulus.rim_radius_px - 150 - 1.0, 0.2};
  EXPECT_TRUE(CensoringOf(camera, at_rim, 2.0).outer);
  EXPECT_FALSE(CensoringOf(camera, at_rim, 0.5).outer);
  BoundingSlice at_blind{annulus.blind_radius_px + 1.0, 0.0, 30, 0.2};
  EXPECT_TRUE(CensoringOf(camera, at_blind, 2.0).inner);
  // The image border: towards the short side (y), a slice reaching the border.
  const double to_border = camera.image_height() / 2.0;
  BoundingSlice at_border{to_border - 40, kPi / 2, 39.8, 0.05};
  if (to_border - 0.5 < annulus.rim_radius_px) {  // the border cuts the mirror's image
    EXPECT_TRUE(CensoringOf(camera, at_border, 0.5).outer);
  }
}

TEST(ObservationModel, ObjectOnTheCameraAxisHasNoSlice) {
  BoundingSlice slice;
  EXPECT_FALSE(PredictSlice(HyperbolicCamera::Preset("lpa"), {1, 1, 0},
                            {Eigen::Vector3d(1, 1, 0), 0.3, 0.3}, &slice));
}

}  // namespace
}  // namespace oslam
