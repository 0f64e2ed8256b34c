// Values of the unknowns of a factor graph: one small vector per variable
// (pose: x, y, theta; base point: x, y, z; cylinder: diameter, height; or any
// other vector), stored contiguously so the solver touches no heap per
// iteration. A variable is referred to by its key, the index it was added at.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace oslam {

class Values {
 public:
  // Adds a variable; `angle_index` names the component that is an angle
  // (wrapped to (-pi, pi] after every update), or -1. Returns its key.
  // (A Ref: a fixed-size vector is passed without a heap copy.)
  int Add(const Eigen::Ref<const Eigen::VectorXd>& value, int angle_index = -1);
  // Room for this many variables and scalars (a graph built per solve).
  void Reserve(int variables, int scalars) {
    offset_.reserve(variables);
    dim_.reserve(variables);
    angle_index_.reserve(variables);
    data_.reserve(scalars);
  }
  int AddPose(double x_m, double y_m, double theta_rad) {
    return Add(Eigen::Vector3d(x_m, y_m, theta_rad), 2);
  }

  int size() const { return static_cast<int>(offset_.size()); }
  int Dim(int key) const { return dim_[key]; }
  int AngleIndex(int key) const { return angle_index_[key]; }
  const double* Data(int key) const { return data_.data() + offset_[key]; }
  double* MutableData(int key) { return data_.data() + offset_[key]; }
  Eigen::Map<const Eigen::VectorXd> Get(int key) const { return {Data(key), dim_[key]}; }
  void Set(int key, const Eigen::VectorXd& value);

  // x <- x + delta (angles wrapped); delta has Dim(key) entries.
  void Retract(int key, const double* delta);

 private:
  std::vector<double> data_;
  std::vector<int> offset_, dim_, angle_index_;
};

}  // namespace oslam
