#include "solver/values.h"

#include "core/angles.h"
#include "core/error.h"

namespace oslam {

int Values::Add(const Eigen::Ref<const Eigen::VectorXd>& value, int angle_index) {
  if (value.size() == 0 || angle_index >= value.size() || angle_index < -1)
    throw Error("Values::Add: a variable needs at least one entry and a valid angle index");
  offset_.push_back(static_cast<int>(data_.size()));
  dim_.push_back(static_cast<int>(value.size()));
  angle_index_.push_back(angle_index);
  data_.insert(data_.end(), value.data(), value.data() + value.size());
  if (angle_index >= 0) data_[offset_.back() + angle_index] = WrapAngle(value[angle_index]);
  return size() - 1;
}

void Values::Set(int key, const Eigen::VectorXd& value) {
  if (value.size() != dim_[key]) throw Error("Values::Set: wrong dimension");
  Eigen::Map<Eigen::VectorXd>(MutableData(key), dim_[key]) = value;
  if (angle_index_[key] >= 0)
    MutableData(key)[angle_index_[key]] = WrapAngle(value[angle_index_[key]]);
}

void Values::Retract(int key, const double* delta) {
  double* x = MutableData(key);
  for (int i = 0; i < dim_[key]; ++i) x[i] += delta[i];
  if (angle_index_[key] >= 0) x[angle_index_[key]] = WrapAngle(x[angle_index_[key]]);
}

}  // namespace oslam
