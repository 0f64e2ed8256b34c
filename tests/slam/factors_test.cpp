// Every factor's analytic Jacobian against central differences, and the
// whitening/normaliser against their definitions.
#include "slam/factors.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/LU>

#include "calib/hyperbolic_camera.h"
#include "calib/observation_model.h"
#include "core/angles.h"
#include "core/error.h"
#include "tests/solver/factor_check.h"
#include "tests/test_util.h"

namespace oslam {
namespace {

using testing::ExpectJacobianMatchesNumeric;

TEST(OdometryFactorTest, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (bool world_frame : {false, true}) {
    MotionNoiseOptions options;
    options.world_frame = world_frame;
    for (int trial = 0; trial < 20; ++trial) {
      Values values;
      const int a = values.AddPose(u(rng), u(rng), 3.0 * u(rng));
      const int b = values.AddPose(u(rng), u(rng), 3.0 * u(rng));
      OdometryFactor factor(a, b, {0.3 * u(rng), 0.3 * u(rng)}, options);
      ExpectJacobianMatchesNumeric(factor, values, 1e-6);
    }
  }
}

TEST(OdometryFactorTest, ZeroErrorOnTheModelAndWhitenedByQ) {
  MotionNoiseOptions options;
  Values values;
  const Pose2 previous{1.0, 2.0, 0.5};
  const OdometryIncrement increment{0.2, DegToRad(10)};
  const Pose2 next = ApplyIncrement(previous, increment);
  const int a = values.AddPose(previous.x, previous.y, previous.theta);
  const int b = values.AddPose(next.x, next.y, next.theta);
  OdometryFactor factor(a, b, increment, options);
  Eigen::VectorXd error(3);
  ASSERT_TRUE(factor.Linearize(values, error, nullptr));
  EXPECT_LT(error.norm(), 1e-12);
  // Off the model, ||e||^2 equals the Mahalanobis distance under Q_i (docs/method.md §4.1).
  const Eigen::Vector3d offset(0.01, -0.02, 0.03);
  values.Set(b, next.Vector() - offset);
  ASSERT_TRUE(factor.Linearize(values, error, nullptr));
  const Eigen::Matrix3d q = MotionCovariance(previous.theta, increment, options);
  EXPECT_NEAR(error.squaredNorm(), offset.dot(q.inverse() * offset), 1e-9);
  EXPECT_NEAR(factor.LogDetCovariance(), std::log(q.determinant()), 1e-9);
}

TEST(BoundingSliceFactorTest, JacobiansMatchCentralDifferences) {
  for (const char* preset : {"lpa", "cogniron"}) {
    const HyperbolicCamera camera = HyperbolicCamera::Preset(preset);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int checked = 0;
    for (int trial = 0; trial < 40; ++trial) {
      Values values;
      const int pose = values.AddPose(u(rng), u(rng), 3.0 * u(rng));
      const double range = 1.0 + 1.5 * (u(rng) + 1.0), bearing = 3.0 * u(rng);
      const Pose2 p{values.Data(pose)[0], values.Data(pose)[1], values.Data(pose)[2]};
      const Eigen::Vector3d base =
          p.RobotToWorld({range * std::cos(bearing), range * std::sin(bearing), 0.1 * u(rng)});
      const int base_key = values.Add(base);
      const int size_key = values.Add(Eigen::Vector2d(0.3 + 0.1 * u(rng), 0.4 + 0.1 * u(rng)));
      BoundingSlice measured{150.0 + 20 * u(rng), u(rng), 20.0, 0.1};
      BoundingSliceFactor factor(&camera, pose, base_key, size_key, measured, 30.0);
      Eigen::VectorXd error(4);
      if (!factor.Linearize(values, error, nullptr)) continue;
      ExpectJacobianMatchesNumeric(factor, values, 1e-5);
      ++checked;
    }
    EXPECT_GT(checked, 30) << preset;
  }
}

TEST(BoundingSliceFactorTest, WhiteningIsRAndTwoRAndAngleResidualWraps) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  Values values;
  const int pose = values.AddPose(0, 0, 0);
  const int base = values.Add(Eigen::Vector3d(2.0, 0.0, 0.0));
  const int size = values.Add(Eigen::Vector2d(0.3, 0.5));
  BoundingSlice truth;
  ASSERT_TRUE(PredictSlice(camera, Pose2{}, {Eigen::Vector3d(2, 0, 0), 0.3, 0.5}, &truth));
  const double e = 30.0;
  BoundingSlice measured = truth;
  measured.u_r_px += 3.0;
  measured.u_phi_rad = WrapAngle(measured.u_phi_rad + 2 * kPi - 0.01);  // across the seam
  measured.s_r_px -= 6.0;
  measured.s_phi_rad += 0.02;
  BoundingSliceFactor factor(&camera, pose, base, size, measured, e);
  Eigen::VectorXd error(4);
  ASSERT_TRUE(factor.Linearize(values, error, nullptr));
  const double ur = measured.u_r_px;
  EXPECT_NEAR(error[0], -3.0 / e, 1e-9);
  EXPECT_NEAR(error[1], 0.01 / (e / ur), 1e-6);
  EXPECT_NEAR(error[2], 6.0 / (std::sqrt(2.0) * e), 1e-9);
  EXPECT_NEAR(error[3], -0.02 / (std::sqrt(2.0) * e / ur), 1e-9);
  // log |R| + log |W| with W = 2R.
  const double log_det_r = std::log(e * e) + std::log(e * e / (ur * ur));
  EXPECT_NEAR(factor.LogDetCovariance(), 2 * log_det_r + 2 * std::log(2.0), 1e-9);
}

// The censored slice factor: numeric Jacobians on both sides of each bound,
// with every silhouette, and slices placed at the rim and the blind disc.
TEST(BoundingSliceFactorTest, CensoredJacobiansMatchCentralDifferences) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const MirrorAnnulus annulus = camera.annulus();
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked[2][2] = {{0, 0}, {0, 0}};  // [outer censored][bound active]
  for (const ObjectShape shape :
       {ObjectShape::kCylinder, ObjectShape::kBox, ObjectShape::kSphere, ObjectShape::kPanel}) {
    SliceModel model;
    model.silhouette = SilhouetteOf(camera, shape, 0.7);
    model.censor_at_image_limits = true;
    for (int trial = 0; trial < 40; ++trial) {
      Values values;
      const int pose = values.AddPose(u(rng), u(rng), 3.0 * u(rng));
      const Pose2 p{values.Data(pose)[0], values.Data(pose)[1], values.Data(pose)[2]};
      const double range = 1.2 + 1.5 * (u(rng) + 1.0), bearing = 3.0 * u(rng);
      const int base_key = values.Add(Eigen::Vector3d(
          p.RobotToWorld({range * std::cos(bearing), range * std::sin(bearing), 0.05 * u(rng)})));
      // Outer end at the rim (trial % 4 < 2: a 2 m top beyond it, or a 0.4 m
      // one short of it) or inner end at the blind disc, read with a margin
      // so wide that slices at any radius touch it (the bound then lies on
      // either side of the prediction).
      const bool tall = trial % 4 < 2;
      const int size_key =
          values.Add(Eigen::Vector2d(0.4 + 0.1 * u(rng), tall && trial % 2 == 0 ? 2.0 : 0.4));
      model.censor_margin_px = tall ? 2.0 : 400.0;
      const BoundingSlice measured =
          tall ? BoundingSlice{150.0 + 10 * u(rng), u(rng),
                               annulus.rim_radius_px - 150.0 - 10 * u(rng), 0.2}
               : BoundingSlice{120.0 + 60 * u(rng), u(rng), 60.0 + 40 * u(rng), 0.2};
      // Keep the end at the limit: re-derive s_r from the rim for tall ones.
      BoundingSlice at_limit = measured;
      if (tall) at_limit.s_r_px = annulus.rim_radius_px - 1.0 - at_limit.u_r_px;
      // A panel's orientation is a fourth key.
      const double yaw = 3.0 * u(rng);
      const int yaw_key =
          model.silhouette.panel ? values.Add(Eigen::Matrix<double, 1, 1>(yaw), 0) : -1;
      BoundingSliceFactor factor(&camera, pose, base_key, size_key, at_limit, 30.0, model, yaw_key);
      ASSERT_EQ(factor.censoring().inner, !tall);  // (the wide margin censors both ends)
      ASSERT_TRUE(factor.censoring().outer);
      Eigen::VectorXd error(4);
      if (!factor.Linearize(values, error, nullptr)) continue;
      // Away from the kink, where the bound switches on.
      const double bound_row = tall ? error[2] : error[0];
      BoundingSlice predicted;
      bool beyond = false;  // a tall top may be beyond the mirror's view: bound met
      ASSERT_TRUE(PredictSlice(camera, p,
                               {values.Get(base_key), values.Data(size_key)[0],
                                values.Data(size_key)[1], yaw_key >= 0 ? yaw : 0.0},
                               &predicted, nullptr, model.silhouette, tall ? &beyond : nullptr));
      const double gap =
          tall ? predicted.u_r_px + predicted.s_r_px - (at_limit.u_r_px + at_limit.s_r_px)
               : predicted.u_r_px - at_limit.u_r_px;
      if (std::abs(gap) < 0.5) continue;
      ExpectJacobianMatchesNumeric(factor, values, 1e-5);
      // A prediction beyond the bound costs nothing in that row.
      const bool active = tall ? gap < 0 : gap > 0;
      if (active) {
        EXPECT_NE(bound_row, 0.0);
      } else {
        EXPECT_EQ(bound_row, 0.0);
      }
      ++checked[tall][active];
    }
  }
  for (int tall = 0; tall < 2; ++tall)
    for (int active = 0; active < 2; ++active)
      EXPECT_GT(checked[tall][active], 3) << "tall " << tall << " active " << active;
}

// A door seen only up to the rim keeps its height: with the outer end
// censored, the fit of one detection series leaves the height at the prior
// instead of shrinking it to what the rim shows.
TEST(BoundingSliceFactorTest, CensoredOuterEndKeepsTheHeightAbovePrediction) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const MirrorAnnulus annulus = camera.annulus();
  SliceModel model;
  model.censor_at_image_limits = true;
  Values values;
  const int pose = values.AddPose(0, 0, 0);
  const int base = values.Add(Eigen::Vector3d(1.5, 0.0, 0.0));
  const int size = values.Add(Eigen::Vector2d(1.0, 2.17));
  BoundingSlice truth;
  ASSERT_TRUE(PredictSlice(camera, Pose2{}, {Eigen::Vector3d(1.5, 0, 0), 1.0, 2.17}, &truth));
  ASSERT_GT(truth.u_r_px + truth.s_r_px, annulus.rim_radius_px);  // beyond the rim
  BoundingSlice measured = truth;
  measured.s_r_px = annulus.rim_radius_px - 0.5 - truth.u_r_px;  // cut at the rim
  BoundingSliceFactor censored(&camera, pose, base, size, measured, 30.0, model);
  BoundingSliceFactor plain(&camera, pose, base, size, measured, 30.0);
  Eigen::VectorXd error(4);
  ASSERT_TRUE(censored.Linearize(values, error, nullptr));
  EXPECT_EQ(error[2], 0.0);  // the true door satisfies the bound
  EXPECT_NEAR(error[0], 0.0, 1e-9);
  ASSERT_TRUE(plain.Linearize(values, error, nullptr));
  EXPECT_GT(error[2], 0.1);  // the plain factor pulls it shorter
  // A door shorter than the rim shows (its top below the camera) costs.
  values.Set(size, Eigen::Vector2d(1.0, 0.6));
  ASSERT_TRUE(censored.Linearize(values, error, nullptr));
  EXPECT_LT(error[2], -0.1);
}

// A panel's slice factor has the panel's yaw as a fourth key.
TEST(BoundingSliceFactorTest, PanelYawJacobianMatchesCentralDifferences) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  SliceModel panel;
  panel.silhouette = SilhouetteOf(camera, ObjectShape::kPanel);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 30; ++trial) {
    Values values;
    const int pose = values.AddPose(u(rng), u(rng), 3.0 * u(rng));
    const Pose2 p{values.Data(pose)[0], values.Data(pose)[1], values.Data(pose)[2]};
    const double range = 2.0 + (u(rng) + 1.0), bearing = 3.0 * u(rng);
    const int base = values.Add(
        p.RobotToWorld({range * std::cos(bearing), range * std::sin(bearing), 0.05 * u(rng)}));
    const int size = values.Add(Eigen::Vector2d(1.0 + 0.1 * u(rng), 0.5 + 0.1 * u(rng)));
    const int yaw = values.Add(Eigen::Matrix<double, 1, 1>(3.0 * u(rng)), 0);
    BoundingSliceFactor factor(&camera, pose, base, size, {150.0, u(rng), 20.0, 0.2}, 30.0, panel,
                               yaw);
    ASSERT_EQ(factor.keys().size(), 4u);
    Eigen::VectorXd error(4);
    if (!factor.Linearize(values, error, nullptr)) continue;
    ExpectJacobianMatchesNumeric(factor, values, 1e-5);
    ++checked;
  }
  EXPECT_GT(checked, 20);
  // A panel needs its yaw, and only a panel has one.
  EXPECT_THROW(BoundingSliceFactor(&camera, 0, 1, 2, {150.0, 0.0, 20.0, 0.2}, 30.0, panel),
               oslam::Error);
  EXPECT_THROW(BoundingSliceFactor(&camera, 0, 1, 2, {150.0, 0.0, 20.0, 0.2}, 30.0, {}, 3),
               oslam::Error);
}

// The yaw prior is flat over the panel's period pi: its normaliser is the
// uniform density 1/pi, and its residual is periodic in pi and small.
TEST(PanelYawPriorTest, NormaliserIsTheFlatDensityAndResidualHasPeriodPi) {
  Values values;
  const int yaw = values.Add(Eigen::Matrix<double, 1, 1>(0.7), 0);
  const PanelYawPrior prior(yaw);
  ExpectJacobianMatchesNumeric(prior, values, 1e-7);
  EXPECT_NEAR(-0.5 * prior.LogDetCovariance() - 0.5 * std::log(2 * kPi), -std::log(kPi), 1e-12);
  for (const double angle : {-3.0, -1.0, 0.2, 1.5, 2.9}) {
    EXPECT_NEAR(PanelYawPrior::Error(angle + kPi), PanelYawPrior::Error(angle), 1e-12);
    EXPECT_LE(std::abs(PanelYawPrior::Error(angle)), 0.5 * kPi / kPanelYawPriorStd + 1e-12);
  }
  EXPECT_NEAR(PanelYawPrior::Error(0.3), 0.3 / kPanelYawPriorStd, 1e-12);
}

TEST(PriorFactorTest, JacobianErrorAndNormaliser) {
  Values values;
  const int key = values.Add(Eigen::Vector3d(1.0, -2.0, 0.5));
  Eigen::Matrix3d covariance;
  covariance << 4.0, 0.5, 0.1, 0.5, 2.0, 0.2, 0.1, 0.2, 1.0;
  const Eigen::Vector3d mean(0.5, 0.5, 0.0);
  PriorFactor factor(key, mean, covariance, "location prior");
  ExpectJacobianMatchesNumeric(factor, values, 1e-7);
  Eigen::VectorXd error(3);
  ASSERT_TRUE(factor.Linearize(values, error, nullptr));
  const Eigen::Vector3d d = values.Get(key) - mean;
  EXPECT_NEAR(error.squaredNorm(), d.dot(covariance.inverse() * d), 1e-12);
  EXPECT_NEAR(factor.LogDetCovariance(), std::log(covariance.determinant()), 1e-12);

  auto size_prior = MakeSizePrior(key + 0, Eigen::Vector2d(0.3, 0.5), Eigen::Vector2d(0.05, 0.1));
  EXPECT_NEAR(size_prior->LogDetCovariance(), std::log(0.05 * 0.05 * 0.1 * 0.1), 1e-12);
  EXPECT_THROW(PriorFactor(key, mean, -covariance), oslam::Error);
}

}  // namespace
}  // namespace oslam
