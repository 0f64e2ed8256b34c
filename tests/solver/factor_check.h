// Shared by the factor tests: a factor's analytic Jacobian against central
// differences of its error over the stacked values of its keys.
#pragma once

#include <gtest/gtest.h>
#include <Eigen/Core>

#include "solver/factor.h"
#include "solver/values.h"
#include "tests/test_util.h"

namespace oslam {
namespace testing {

// Compares a factor's Jacobian with central differences of its error over
// the stacked key values.
inline void ExpectJacobianMatchesNumeric(const Factor& factor, const Values& values,
                                         double tolerance) {
  int total = 0;
  for (int key : factor.keys()) total += values.Dim(key);
  Eigen::VectorXd stacked(total);
  int at = 0;
  for (int key : factor.keys()) {
    stacked.segment(at, values.Dim(key)) = values.Get(key);
    at += values.Dim(key);
  }
  auto error_at = [&](const Eigen::VectorXd& x) {
    Values perturbed = values;
    int offset = 0;
    for (int key : factor.keys()) {
      // Set without wrapping so the difference quotient stays continuous.
      Eigen::Map<Eigen::VectorXd>(perturbed.MutableData(key), values.Dim(key)) =
          x.segment(offset, values.Dim(key));
      offset += values.Dim(key);
    }
    Eigen::VectorXd error(factor.Dimension());
    EXPECT_TRUE(factor.Linearize(perturbed, error, nullptr));
    return error;
  };
  Eigen::VectorXd error(factor.Dimension());
  Eigen::MatrixXd jacobian(factor.Dimension(), total);
  ASSERT_TRUE(factor.Linearize(values, error, &jacobian));
  EXPECT_TRUE(error.isApprox(error_at(stacked)));
  const Eigen::MatrixXd numeric = NumericJacobian(error_at, stacked, 1e-6);
  const Eigen::MatrixXd difference = jacobian - numeric;
  EXPECT_LT(difference.lpNorm<Eigen::Infinity>(), tolerance) << factor.Name() << "\nanalytic\n"
                                                             << jacobian << "\nnumeric\n"
                                                             << numeric;
}

}  // namespace testing
}  // namespace oslam
