#include "solver/factor_graph.h"

#include <algorithm>
#include <string>

#include "core/error.h"

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
