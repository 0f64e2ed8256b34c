#include "mapping/values.h"

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

#include "mapping/factor_graph.h"

#include <algorithm>

namespace oslam {

void FactorGraph::Add(FactorPtr factor) {
  if (!factor) throw Error("FactorGraph::Add: null factor");
  for (int key : factor->keys())
    if (key < 0 || key >= values_.size())
      throw Error("FactorGraph::Add: " + factor->Name() + " factor refers to unknown variable " +
                  std::to_string(key));
  factors_.push_back(std::move(factor));
}

void* FactorGraph::Allocate(std::size_t size, std::size_t alignment) {
  std::size_t start = (arena_used_ + alignment - 1) / alignment * alignment;
  if (arena_.empty() || start + size > arena_size_) {
    arena_size_ = std::max(kArenaBlock, size);
    arena_.emplace_back(
        static_cast<std::byte*>(::operator new(arena_size_, std::align_val_t(kArenaAlignment))));
    start = 0;
  }
  arena_used_ = start + size;
  return arena_.back().get() + start;
}

}  // namespace oslam
