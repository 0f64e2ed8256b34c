#include "solver/values.h"

#include <gtest/gtest.h>

#include "core/angles.h"
#include "core/error.h"

namespace oslam {
namespace {

TEST(ValuesTest, AddStoresVariablesContiguouslyUnderConsecutiveKeys) {
  Values values;
  const int pose = values.AddPose(1.0, 2.0, 0.5);
  const int point = values.Add(Eigen::Vector3d(4.0, 5.0, 6.0));
  const int size = values.Add(Eigen::Vector2d(0.3, 0.7));
  EXPECT_EQ(pose, 0);
  EXPECT_EQ(point, 1);
  EXPECT_EQ(size, 2);
  EXPECT_EQ(values.size(), 3);
  EXPECT_EQ(values.Dim(pose), 3);
  EXPECT_EQ(values.Dim(size), 2);
  EXPECT_EQ(values.AngleIndex(pose), 2);
  EXPECT_EQ(values.AngleIndex(point), -1);
  EXPECT_EQ(values.Get(point), Eigen::Vector3d(4.0, 5.0, 6.0));
  // One block of memory: each variable follows the one before.
  EXPECT_EQ(values.Data(point), values.Data(pose) + 3);
  EXPECT_EQ(values.Data(size), values.Data(point) + 3);
}

TEST(ValuesTest, AnglesAreWrappedOnAddSetAndRetract) {
  Values values;
  const int pose = values.AddPose(0.0, 0.0, 3.0 * kPi / 2.0);
  EXPECT_DOUBLE_EQ(values.Get(pose)[2], -kPi / 2.0);

  values.Set(pose, Eigen::Vector3d(1.0, 1.0, -5.0 * kPi / 4.0));
  EXPECT_DOUBLE_EQ(values.Get(pose)[2], 3.0 * kPi / 4.0);
  EXPECT_EQ(values.Get(pose).head<2>(), Eigen::Vector2d(1.0, 1.0));

  // 3 pi / 4 + pi / 2 = 5 pi / 4, wrapped to -3 pi / 4; x and y just add.
  const double delta[3] = {0.5, -2.0, kPi / 2.0};
  values.Retract(pose, delta);
  EXPECT_DOUBLE_EQ(values.Get(pose)[0], 1.5);
  EXPECT_DOUBLE_EQ(values.Get(pose)[1], -1.0);
  EXPECT_DOUBLE_EQ(values.Get(pose)[2], -3.0 * kPi / 4.0);

  // pi itself stays pi (the range is (-pi, pi]); -pi becomes pi.
  values.Set(pose, Eigen::Vector3d(0.0, 0.0, kPi));
  EXPECT_EQ(values.Get(pose)[2], kPi);
  values.Set(pose, Eigen::Vector3d(0.0, 0.0, -kPi));
  EXPECT_EQ(values.Get(pose)[2], kPi);
}

TEST(ValuesTest, ANonAngleComponentIsNeverWrapped) {
  Values values;
  const int key = values.Add(Eigen::Vector2d(10.0, 0.0), /*angle_index=*/1);
  const double delta[2] = {20.0, 7.0};
  values.Retract(key, delta);
  EXPECT_DOUBLE_EQ(values.Get(key)[0], 30.0);
  EXPECT_NEAR(values.Get(key)[1], 7.0 - 2.0 * kPi, 1e-15);
}

TEST(ValuesTest, RetractTouchesOnlyItsVariable) {
  Values values;
  const int a = values.Add(Eigen::Vector2d(1.0, 2.0));
  const int b = values.Add(Eigen::Vector2d(3.0, 4.0));
  const double delta[2] = {0.25, 0.5};
  values.Retract(b, delta);
  EXPECT_EQ(values.Get(a), Eigen::Vector2d(1.0, 2.0));
  EXPECT_EQ(values.Get(b), Eigen::Vector2d(3.25, 4.5));
}

TEST(ValuesTest, RejectsEmptyVariablesBadAngleIndicesAndWrongSizes) {
  Values values;
  EXPECT_THROW(values.Add(Eigen::VectorXd()), Error);
  EXPECT_THROW(values.Add(Eigen::Vector2d(1.0, 2.0), 2), Error);
  EXPECT_THROW(values.Add(Eigen::Vector2d(1.0, 2.0), -2), Error);
  EXPECT_EQ(values.size(), 0);
  const int key = values.Add(Eigen::Vector2d(1.0, 2.0));
  EXPECT_THROW(values.Set(key, Eigen::Vector3d(1.0, 2.0, 3.0)), Error);
  EXPECT_EQ(values.Get(key), Eigen::Vector2d(1.0, 2.0));
}

}  // namespace
}  // namespace oslam
