// A factor graph: the variables' current values, which of them are held
// fixed (the gauge: pose 1 is excluded from the unknowns, docs/method.md §14), and the
// factors. The solver reads the structure and updates the values in place.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include "solver/factor.h"
#include "solver/values.h"

namespace oslam {

class FactorGraph {
 public:
  int AddVariable(const Eigen::Ref<const Eigen::VectorXd>& value, int angle_index = -1,
                  bool fixed = false) {
    fixed_.push_back(fixed);
    return values_.Add(value, angle_index);
  }
  int AddPose(double x_m, double y_m, double theta_rad, bool fixed = false) {
    return AddVariable(Eigen::Vector3d(x_m, y_m, theta_rad), 2, fixed);
  }
  // Room for this many variables (and scalars) and factors.
  void Reserve(int variables, int scalars, int factors) {
    values_.Reserve(variables, scalars);
    fixed_.reserve(variables);
    factors_.reserve(factors);
  }
  // A factor owned by the graph: made by Emplace in the graph's arena, or
  // handed over by Add from the heap.
  struct FactorDeleter {
    bool in_arena = false;
    void operator()(Factor* factor) const {
      if (in_arena)
        factor->~Factor();
      else
        delete factor;
    }
  };
  using FactorPtr = std::unique_ptr<Factor, FactorDeleter>;

  // Throws oslam::Error when a key is unknown.
  void Add(std::unique_ptr<Factor> factor) { Add(FactorPtr(factor.release())); }
  // Constructs the factor in the graph's arena: an O-SLAM proposal builds a
  // graph of ~2,000 factors, and one heap block each (made and freed per
  // proposal) was ~4 % of its time.
  template <typename F, typename... Args>
  F* Emplace(Args&&... args) {
    static_assert(alignof(F) <= kArenaAlignment, "the arena's blocks are not aligned for it");
    F* factor = new (Allocate(sizeof(F), alignof(F))) F(std::forward<Args>(args)...);
    Add(FactorPtr(factor, FactorDeleter{true}));
    return factor;
  }

  const Values& values() const { return values_; }
  Values& mutable_values() { return values_; }
  bool IsFixed(int key) const { return fixed_[key]; }
  void SetFixed(int key, bool fixed) { fixed_[key] = fixed; }
  int num_variables() const { return values_.size(); }
  const std::vector<FactorPtr>& factors() const { return factors_; }

 private:
  void Add(FactorPtr factor);
  // Bump allocation in blocks of kArenaBlock bytes (larger objects get a
  // block of their own); nothing is freed before the graph.
  void* Allocate(std::size_t size, std::size_t alignment);
  static constexpr std::size_t kArenaBlock = 64 * 1024, kArenaAlignment = 64;
  struct BlockDeleter {
    void operator()(std::byte* block) const {
      ::operator delete(block, std::align_val_t(kArenaAlignment));
    }
  };

  Values values_;
  std::vector<bool> fixed_;
  // Declared before factors_, so the factors are destroyed first.
  std::vector<std::unique_ptr<std::byte, BlockDeleter>> arena_;
  std::size_t arena_used_ = 0, arena_size_ = 0;
  std::vector<FactorPtr> factors_;
};

}  // namespace oslam
