#include "association/association_state.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <sstream>

#include "core/error.h"

namespace oslam {

void AssociationState::Canonicalize() {
  std::vector<std::pair<std::vector<int>, int>> pairs;
  for (size_t j = 0; j < blocks.size(); ++j) {
    std::vector<int> block = blocks[j];
    std::sort(block.begin(), block.end());
    if (!block.empty()) pairs.push_back({std::move(block), classes.at(j)});
  }
  std::sort(pairs.begin(), pairs.end());
  blocks.clear();
  classes.clear();
  for (auto& [block, c] : pairs) {
    blocks.push_back(std::move(block));
    classes.push_back(c);
  }
}

int AssociationState::BlockOf(int track) const {
  for (size_t j = 0; j < blocks.size(); ++j)
    if (std::binary_search(blocks[j].begin(), blocks[j].end(), track)) return static_cast<int>(j);
  return -1;
}

AssociationState AssociationState::WithTrackMoved(int track, int target_block,
                                                  int joined_class) const {
  // This state is canonical: only the objects the track leaves and joins
  // change, so they alone are taken out and put back in order (the objects
  // are disjoint, so their order is that of their first tracks).
  AssociationState moved = *this;
  const int from = BlockOf(track);
  std::vector<int> out;   // the indices of the objects taken out
  std::vector<int> left;  // the object the track leaves, without it
  if (from >= 0) {
    left = std::move(moved.blocks[from]);
    left.erase(std::find(left.begin(), left.end(), track));
    out.push_back(from);
  }
  std::vector<int> joined;  // the object it ends in
  if (target_block >= 0 && target_block == from) {
    joined = std::move(left);
    left.clear();
  } else if (target_block >= 0) {
    joined = std::move(moved.blocks[target_block]);
    out.push_back(target_block);
  }
  joined.insert(std::lower_bound(joined.begin(), joined.end(), track), track);
  std::vector<std::pair<std::vector<int>, int>> changed;  // (object, class) to put back
  if (!left.empty()) changed.push_back({std::move(left), classes[from]});
  changed.push_back({std::move(joined), joined_class});
  std::sort(out.rbegin(), out.rend());
  for (int j : out) {
    moved.blocks.erase(moved.blocks.begin() + j);
    moved.classes.erase(moved.classes.begin() + j);
  }
  for (auto& [block, c] : changed) {
    const auto at =
        std::lower_bound(moved.blocks.begin(), moved.blocks.end(), block.front(),
                         [](const std::vector<int>& b, int first) { return b.front() < first; });
    moved.classes.insert(moved.classes.begin() + (at - moved.blocks.begin()), c);
    moved.blocks.insert(at, std::move(block));
  }
  return moved;
}

AssociationState AssociationState::WithBlocksMerged(int a, int b) const {
  if (a == b) throw Error("AssociationState::WithBlocksMerged: an object with itself");
  const int first = std::min(a, b), second = std::max(a, b);
  AssociationState merged;
  merged.blocks.reserve(blocks.size() - 1);
  merged.classes.reserve(blocks.size() - 1);
  for (size_t j = 0; j < blocks.size(); ++j) {
    if (static_cast<int>(j) == second) continue;
    if (static_cast<int>(j) != first) {
      merged.blocks.push_back(blocks[j]);
      merged.classes.push_back(classes[j]);
      continue;
    }
    std::vector<int> both;
    both.reserve(blocks[first].size() + blocks[second].size());
    std::merge(blocks[first].begin(), blocks[first].end(), blocks[second].begin(),
               blocks[second].end(), std::back_inserter(both));
    merged.blocks.push_back(std::move(both));
    merged.classes.push_back(classes[first]);
  }
  return merged;
}

size_t AssociationState::num_tracks() const {
  size_t n = 0;
  for (const auto& block : blocks) n += block.size();
  return n;
}

std::string AssociationState::ToString() const {
  std::ostringstream out;
  for (size_t j = 0; j < blocks.size(); ++j) {
    out << (j ? " {" : "{");
    for (size_t k = 0; k < blocks[j].size(); ++k) out << (k ? "," : "") << blocks[j][k];
    out << "}:" << classes[j];
  }
  return out.str();
}

size_t AssociationStateHash::operator()(const AssociationState& state) const {
  // FNV-1a over the canonical sequence, with separators between blocks.
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](uint64_t v) {
    h ^= v + 0x9e3779b97f4a7c15ull;
    h *= 1099511628211ull;
  };
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    for (int t : state.blocks[j]) mix(static_cast<uint64_t>(t));
    mix(0xfffffffful + static_cast<uint64_t>(state.classes[j]));
  }
  return static_cast<size_t>(h);
}

AssociationState SeparateTracksState(const std::vector<int>& track_classes) {
  AssociationState state;
  for (size_t t = 0; t < track_classes.size(); ++t) {
    state.blocks.push_back({static_cast<int>(t)});
    state.classes.push_back(track_classes[t]);
  }
  return state;
}

ClassConfusionModel::ClassConfusionModel(const std::vector<std::vector<double>>& confusion,
                                         double floor, std::vector<int> track_class,
                                         std::vector<int> track_size)
    : track_class_(std::move(track_class)), track_size_(std::move(track_size)) {
  const size_t n = confusion.size();
  if (n == 0) throw Error("the class confusion matrix is empty");
  if (!(floor >= 0 && floor < 1)) throw Error("the confusion floor must be in [0, 1)");
  if (track_class_.size() != track_size_.size())
    throw Error("track classes and sizes differ in length");
  for (const auto& row : confusion) {
    if (row.size() != n) throw Error("the class confusion matrix must be square");
    std::vector<double> p(n);
    for (size_t a = 0; a < n; ++a) p[a] = std::max(row[a], floor);
    const double sum = std::accumulate(p.begin(), p.end(), 0.0);
    if (!(sum > 0)) throw Error("a confusion row has no positive entry");
    std::vector<double> log_row(n);
    for (size_t a = 0; a < n; ++a) log_row[a] = std::log(p[a] / sum);
    log_confusion_.push_back(std::move(log_row));
  }
  for (int a : track_class_)
    if (a < 0 || a >= static_cast<int>(n)) throw Error("a track's class is out of range");
}

ClassConfusionModel ClassConfusionModel::Identity(int num_classes, double floor,
                                                  std::vector<int> track_class,
                                                  std::vector<int> track_size) {
  std::vector<std::vector<double>> confusion(num_classes, std::vector<double>(num_classes, 0.0));
  for (int c = 0; c < num_classes; ++c) confusion[c][c] = 1.0;
  return ClassConfusionModel(confusion, floor, std::move(track_class), std::move(track_size));
}

double ClassConfusionModel::BlockLogLikelihood(const std::vector<int>& block, int c) const {
  double sum = 0;
  for (int t : block) sum += track_size_[t] * log_confusion_[c][track_class_[t]];
  return sum;
}

std::vector<double> ClassConfusionModel::ClassLogProposal(const std::vector<int>& block) const {
  std::vector<double> log_q(num_classes());
  for (int c = 0; c < num_classes(); ++c) log_q[c] = BlockLogLikelihood(block, c);
  const double max = *std::max_element(log_q.begin(), log_q.end());
  double sum = 0;
  for (double v : log_q) sum += std::exp(v - max);
  const double log_norm = max + std::log(sum);
  for (double& v : log_q) v -= log_norm;
  return log_q;
}

EvaluationPtr EvaluationCache::Find(const AssociationState& state) {
  const auto found = entries_.find(state);
  if (found == entries_.end()) return nullptr;
  ++hits_;
  return found->second;
}

void EvaluationCache::Clear() {
  if (journaling_) throw Error("EvaluationCache::Clear after Mark()");
  entries_ = Map();
}

void EvaluationCache::Store(const EvaluationPtr& evaluation) {
  if (entries_.size() >= max_entries_) {
    if (journaling_) {
      Change change;
      change.cleared = std::make_unique<Map>(std::move(entries_));
      journal_.push_back(std::move(change));
    }
    entries_ = Map();
  }
  EvaluationPtr& entry = entries_[evaluation->state];
  if (journaling_) {
    Change change;
    change.key = evaluation->state;
    change.previous = entry;
    journal_.push_back(std::move(change));
  }
  entry = evaluation;
}

size_t EvaluationCache::Mark() {
  journaling_ = true;
  Change change;
  change.is_mark = true;
  change.solves = solves_;
  change.hits = hits_;
  journal_.push_back(std::move(change));
  return journal_begin_ + journal_.size() - 1;
}

void EvaluationCache::RollBack(size_t mark) {
  if (mark < journal_begin_ || mark >= journal_begin_ + journal_.size() ||
      !journal_[mark - journal_begin_].is_mark)
    throw Error("evaluation cache: roll-back to a mark that was released or never made");
  while (journal_begin_ + journal_.size() > mark + 1) {
    Change& change = journal_.back();
    if (change.cleared) {
      entries_ = std::move(*change.cleared);
    } else if (!change.is_mark) {
      if (change.previous)
        entries_[change.key] = std::move(change.previous);
      else
        entries_.erase(change.key);
    }
    journal_.pop_back();
  }
  solves_ = journal_.back().solves;
  hits_ = journal_.back().hits;
}

void EvaluationCache::Release(size_t mark) {
  while (!journal_.empty() && journal_begin_ < mark) {
    journal_.pop_front();
    ++journal_begin_;
  }
}

}  // namespace oslam
