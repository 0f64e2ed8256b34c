#include "association/moves.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "core/pair_key.h"

namespace oslam {
namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

double LogSumExp(const std::vector<double>& v) {
  double max = kNegInf;
  for (double x : v) max = std::max(max, x);
  if (max == kNegInf) return kNegInf;
  double sum = 0;
  for (double x : v) sum += std::exp(x - max);
  return max + std::log(sum);
}

double LogOf(double p) {
  return p > 0 ? std::log(p) : kNegInf;
}

// log q(c | Psi) of the class a move draws: the data-driven proposal of
// Algorithms 5-7 (prod P(a | c)) mixed with a uniform one. The data-driven
// part alone almost never proposes a class the detector rarely reports (an
// orange door seen as orange balls: (P(ball|door) / P(ball|ball))^n for n
// detections), although the geometric evidence (the size prior) may favour
// it strongly; the uniform part keeps such classes reachable.
std::vector<double> LogClassProposal(const ClassConfusionModel& model,
                                     const std::vector<int>& block, const MoveOptions& options) {
  std::vector<double> log_q = model.ClassLogProposal(block);
  const double mix = options.class_proposal_uniform;
  if (mix <= 0) return log_q;
  const double log_uniform = std::log(mix / static_cast<double>(log_q.size()));
  const double log_data = std::log1p(-mix);
  for (double& x : log_q) x = LogSumExp({log_data + x, log_uniform});
  return log_q;
}

// log d~_j normalised (Algorithm 5 steps 2-3); false if all are zero. The
// neighbours within d_thr are found in a grid of d_thr cells (x, y) instead
// of among all pairs: the same counts, in time linear in the objects (a
// landmark map holds thousands, and every merge proposal needs them).
bool MergeFirstWeights(const StateEvaluation& s, const MoveOptions& options,
                       std::vector<double>* log_d) {
  const size_t n = s.state.blocks.size();
  const double d = options.merge_distance_m;
  log_d->assign(n, kNegInf);
  const auto cell_of = [d](double v) { return static_cast<long long>(std::floor(v / d)); };
  std::unordered_map<long long, std::vector<int>> cells;
  bool finite = std::isfinite(d);
  for (size_t k = 0; k < n && finite; ++k) {
    finite = std::isfinite(s.locations[k].x()) && std::isfinite(s.locations[k].y());
    if (finite)
      cells[PairKey(cell_of(s.locations[k].x()), cell_of(s.locations[k].y()))].push_back(
          static_cast<int>(k));
  }
  for (size_t j = 0; j < n; ++j) {
    double count = options.merge_count_includes_self ? 1.0 : 0.0;
    const auto near = [&](size_t k) {
      return k != j && s.state.classes[k] == s.state.classes[j] &&
             (s.locations[k] - s.locations[j]).norm() < d;
    };
    if (!finite) {  // no grid: every pair
      for (size_t k = 0; k < n; ++k) count += near(k) ? 1.0 : 0.0;
    } else {
      const long long cx = cell_of(s.locations[j].x()), cy = cell_of(s.locations[j].y());
      for (long long x = cx - 1; x <= cx + 1; ++x)
        for (long long y = cy - 1; y <= cy + 1; ++y) {
          const auto cell = cells.find(PairKey(x, y));
          if (cell == cells.end()) continue;
          for (int k : cell->second) count += near(static_cast<size_t>(k)) ? 1.0 : 0.0;
        }
    }
    (*log_d)[j] = LogOf(count + options.merge_count_smoothing);
  }
  return NormaliseLog(log_d);
}

// log eps_j = -e_j / 2 for j != j1 (Algorithm 5 step 4), unnormalised;
// -infinity for j1 itself and across classes with an infinite penalty.
std::vector<double> LogPartnerWeights(const StateEvaluation& s, int j1, double sigma_m,
                                      const MoveOptions& options) {
  const size_t n = s.state.blocks.size();
  std::vector<double> log_e(n, kNegInf);
  const double sigma2 = sigma_m * sigma_m;
  for (size_t j = 0; j < n; ++j) {
    if (static_cast<int>(j) == j1) continue;
    double e = (s.locations[j] - s.locations[j1]).squaredNorm() / sigma2;
    if (s.state.classes[j] != s.state.classes[j1]) {
      if (std::isinf(options.class_mismatch_penalty)) continue;
      e *= options.class_mismatch_penalty;
    }
    log_e[j] = -0.5 * e;
  }
  return log_e;
}

// log eps_j normalised over j != j1 (Algorithm 5 steps 4 and 6).
bool MergePartnerWeights(const StateEvaluation& s, int j1, const MoveOptions& options,
                         std::vector<double>* log_e) {
  *log_e = LogPartnerWeights(s, j1, options.merge_sigma_m, options);
  return NormaliseLog(log_e);
}

// log P(a_t | c) per detector decision of one track: the track's class
// likelihood divided by the decisions it counts for, so that long and short
// tracks weigh alike.
double LogTrackFit(const ClassConfusionModel& model, int track, int c) {
  return model.BlockLogLikelihood({track}, c) / std::max(1, model.track_size(track));
}

// Where `track` of object `from` may go (reassign, docs/method.md §9.2): every
// other object k with exp(-|l_k - l_from|^2 / (2 sigma_R^2)) P(a_t | c_k) (an
// object of one or two tracks is often placed far along its viewing rays, so
// the class the track's detections fit counts more than the distance), zero
// across classes with an infinite mismatch penalty; last (index = number of
// objects) alone, weighted as an object at d_thr of the track's best-fitting
// class would be. Alone is no move for a track alone already. Normalised;
// false when the track can go nowhere.
bool ReassignWeights(const StateEvaluation& s, int from, int track,
                     const ClassConfusionModel& model, const MoveOptions& options,
                     std::vector<double>* log_w) {
  const size_t n = s.state.blocks.size();
  const double sigma2 = options.reassign_sigma_m * options.reassign_sigma_m;
  log_w->assign(n + 1, kNegInf);
  double best_fit = kNegInf;
  for (int c = 0; c < model.num_classes(); ++c)
    best_fit = std::max(best_fit, LogTrackFit(model, track, c));
  for (size_t k = 0; k < n; ++k) {
    if (static_cast<int>(k) == from) continue;
    if (std::isinf(options.class_mismatch_penalty) && s.state.classes[k] != s.state.classes[from])
      continue;
    (*log_w)[k] = -0.5 * (s.locations[k] - s.locations[from]).squaredNorm() / sigma2 +
                  LogTrackFit(model, track, s.state.classes[k]);
  }
  const double alone = options.merge_distance_m / options.reassign_sigma_m;
  if (s.state.blocks[from].size() > 1) (*log_w)[n] = -0.5 * alone * alone + best_fit;
  return NormaliseLog(log_w);
}

// How likely reassign picks each track (docs/method.md §9.2): weight
// 1 + kappa (1 - P(a_t | c_j)) + kappa [t is alone], kappa =
// reassign_focus. The tracks that move in a posterior are those whose
// detected class disagrees with their object's and those alone; a uniform
// draw over ~60 tracks seldom picks them. Normalised over all tracks; indexed
// by track id (-infinity for ids the state does not hold).
std::vector<double> ReassignTrackWeights(const StateEvaluation& s, const ClassConfusionModel& model,
                                         const MoveOptions& options) {
  int max_track = -1;
  for (const std::vector<int>& block : s.state.blocks)
    for (int t : block) max_track = std::max(max_track, t);
  std::vector<double> log_w(static_cast<size_t>(max_track + 1), kNegInf);
  const double kappa = options.reassign_focus;
  for (size_t j = 0; j < s.state.blocks.size(); ++j) {
    const std::vector<int>& block = s.state.blocks[j];
    for (int t : block) {
      const double misfit = -std::expm1(LogTrackFit(model, t, s.state.classes[j]));
      log_w[t] = std::log(1.0 + kappa * misfit + (block.size() == 1 ? kappa : 0.0));
    }
  }
  NormaliseLog(&log_w);
  return log_w;
}

// Split weights r^2(j), zero for single-track objects (#19).
bool SplitWeights(const StateEvaluation& s, std::vector<double>* log_w) {
  const size_t n = s.state.blocks.size();
  log_w->assign(n, kNegInf);
  for (size_t j = 0; j < n; ++j)
    if (s.state.blocks[j].size() >= 2) (*log_w)[j] = LogOf(s.residual2[j]);
  return NormaliseLog(log_w);
}

double LogPartitionProbability(size_t n, size_t second_size, SplitSampler sampler) {
  const double uniform = 1.0 / (std::pow(2.0, double(n) - 1.0) - 1.0);
  if (sampler == SplitSampler::kUniform) return std::log(uniform);
  if (sampler == SplitSampler::kOneTrackOrUniform) {
    // The single tracks whose splitting off gives this partition: the second
    // part itself, or the earliest track (the second part is then the rest).
    const double singles = double(second_size == 1) + double(second_size == n - 1);
    return std::log(0.5 * singles / double(n) + 0.5 * uniform);
  }
  return std::log(double(second_size) / double(n - 1)) - double(n - 2) * std::log(2.0);
}

std::vector<int> Union(const std::vector<int>& a, const std::vector<int>& b) {
  std::vector<int> u;
  std::merge(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(u));
  return u;
}

Proposal ProposeMerge(const StateEvaluation& s, const ClassConfusionModel& model,
                      const MoveOptions& options, const MoveProbabilities& probabilities,
                      Rng& rng) {
  Proposal p;
  p.type = MoveType::kMerge;
  std::vector<double> log_d, log_e;
  if (s.state.blocks.size() < 2 || !MergeFirstWeights(s, options, &log_d)) return p;
  const int j1 = SampleLog(log_d, rng);
  if (!MergePartnerWeights(s, j1, options, &log_e)) return p;  // #42: self-transition
  const int j2 = SampleLog(log_e, rng);
  p.part_a = s.state.blocks[j1];
  p.part_b = s.state.blocks[j2];
  p.old_class_a = s.state.classes[j1];
  p.old_class_b = s.state.classes[j2];
  p.state = s.state.WithBlocksMerged(j1, j2);
  const int merged = std::min(j1, j2);  // the merged object's index
  const int c = SampleLog(LogClassProposal(model, p.state.blocks[merged], options), rng);
  p.state.classes[merged] = c;
  p.log_q_forward = LogMergeProbability(s, j1, j2, c, model, options, probabilities);
  p.self_transition = false;
  return p;
}

// Algorithm 6 step 4: the earliest track stays in the first part.
std::vector<int> SampleSecondPart(const std::vector<int>& block, SplitSampler sampler, Rng& rng) {
  std::bernoulli_distribution coin(0.5);
  std::vector<int> second;
  if (sampler == SplitSampler::kOneTrackOrUniform) {
    if (coin(rng)) {
      const size_t alone = std::uniform_int_distribution<size_t>(0, block.size() - 1)(rng);
      if (alone == 0) return std::vector<int>(block.begin() + 1, block.end());
      return {block[alone]};
    }
    sampler = SplitSampler::kUniform;
  }
  if (sampler == SplitSampler::kUniform) {
    while (second.empty())
      for (size_t k = 1; k < block.size(); ++k)
        if (coin(rng)) second.push_back(block[k]);
    return second;
  }
  const size_t chosen = 1 + std::uniform_int_distribution<size_t>(0, block.size() - 2)(rng);
  for (size_t k = 1; k < block.size(); ++k)
    if (k == chosen || coin(rng)) second.push_back(block[k]);
  return second;
}

Proposal ProposeSplit(const StateEvaluation& s, const ClassConfusionModel& model,
                      const MoveOptions& options, const MoveProbabilities& probabilities,
                      Rng& rng) {
  Proposal p;
  p.type = MoveType::kSplit;
  std::vector<double> log_w;
  if (!SplitWeights(s, &log_w)) return p;
  const int j = SampleLog(log_w, rng);
  const std::vector<int>& block = s.state.blocks[j];
  p.part_b = SampleSecondPart(block, options.split_sampler, rng);
  std::set_difference(block.begin(), block.end(), p.part_b.begin(), p.part_b.end(),
                      std::back_inserter(p.part_a));
  p.old_class_a = s.state.classes[j];
  const int ca = SampleLog(LogClassProposal(model, p.part_a, options), rng);
  const int cb = SampleLog(LogClassProposal(model, p.part_b, options), rng);
  p.state = s.state;
  p.state.blocks[j] = p.part_a;
  p.state.classes[j] = ca;
  p.state.blocks.push_back(p.part_b);
  p.state.classes.push_back(cb);
  p.state.Canonicalize();
  p.log_q_forward =
      LogSplitProbability(s, j, p.part_a, p.part_b, ca, cb, model, options, probabilities);
  p.self_transition = false;
  return p;
}

std::vector<double> SwitchWeights(const StateEvaluation& s, const ClassConfusionModel& model) {
  std::vector<double> log_p(s.state.blocks.size());
  for (size_t j = 0; j < log_p.size(); ++j)
    log_p[j] = LogOf(-std::expm1(model.BlockLogLikelihood(s.state.blocks[j], s.state.classes[j])));
  return log_p;
}

// q(c | Psi_j) over the classes other than c_j, renormalised (beyond
// Algorithm 7, docs/method.md §9.2): drawing the current class again was a
// self-transition, 85 % of switch proposals on long_loop. Empty when no other
// class is possible.
std::vector<double> SwitchClassProposal(const StateEvaluation& s, int block,
                                        const ClassConfusionModel& model,
                                        const MoveOptions& options) {
  std::vector<double> log_q = LogClassProposal(model, s.state.blocks[block], options);
  log_q[s.state.classes[block]] = kNegInf;
  if (!NormaliseLog(&log_q)) return {};
  return log_q;
}

Proposal ProposeSwitch(const StateEvaluation& s, const ClassConfusionModel& model,
                       const MoveOptions& options, const MoveProbabilities& probabilities,
                       Rng& rng) {
  Proposal p;
  p.type = MoveType::kSwitch;
  std::vector<double> log_p = SwitchWeights(s, model);
  if (!NormaliseLog(&log_p)) return p;
  const int j = SampleLog(log_p, rng);
  std::vector<double> log_q = SwitchClassProposal(s, j, model, options);
  if (log_q.empty()) return p;
  const int c = SampleLog(log_q, rng);
  p.track = s.state.blocks[j].front();
  p.old_class_a = s.state.classes[j];
  p.state = s.state;
  p.state.classes[j] = c;
  p.log_q_forward = LogSwitchProbability(s, j, c, model, options, probabilities);
  p.self_transition = false;
  return p;
}

// Reassign (beyond the thesis): a track (ReassignTrackWeights) leaves its object
// for a nearby object or becomes an object alone (ReassignWeights); the two
// objects it changes draw their classes from the class proposal, as a merge
// and a split do: the object it joins (or it alone) from q(c | its tracks),
// what it leaves (unless empty) from q(c | the rest).
Proposal ProposeReassign(const StateEvaluation& s, const ClassConfusionModel& model,
                         const MoveOptions& options, const MoveProbabilities& probabilities,
                         Rng& rng) {
  Proposal p;
  p.type = MoveType::kReassign;
  if (s.state.blocks.empty() || !(probabilities.reassign > 0)) return p;
  const int track = SampleLog(ReassignTrackWeights(s, model, options), rng);
  const int from = s.state.BlockOf(track);
  const std::vector<int>& block = s.state.blocks[from];
  std::vector<double> log_w;
  if (!ReassignWeights(s, from, track, model, options, &log_w)) return p;
  const int target = SampleLog(log_w, rng);
  const bool alone = target == static_cast<int>(s.state.blocks.size());
  p.track = track;
  p.old_class_a = s.state.classes[from];
  std::copy_if(block.begin(), block.end(), std::back_inserter(p.part_a),
               [track](int t) { return t != track; });
  std::vector<int> joined = {track};
  if (!alone) {
    p.part_b = s.state.blocks[target];
    p.old_class_b = s.state.classes[target];
    joined = Union(p.part_b, {track});
  }
  const int joined_class = SampleLog(LogClassProposal(model, joined, options), rng);
  const int rest_class =
      p.part_a.empty() ? 0 : SampleLog(LogClassProposal(model, p.part_a, options), rng);
  p.state = s.state.WithTrackMoved(track, alone ? -1 : target, joined_class);
  if (!p.part_a.empty()) p.state.classes[p.state.BlockOf(p.part_a.front())] = rest_class;
  p.log_q_forward = LogReassignProbability(s, track, alone ? -1 : target, joined_class, rest_class,
                                           model, options, probabilities);
  p.self_transition = false;
  return p;
}

// The forward and the reverse probability of a move are the probabilities
// of a merge or a split given by the track sets involved, evaluated on the
// state the move starts from or on the state it proposed.

// log q of merging the objects that hold `part_a` and `part_b` in `s` into
// one of class `merged_class`.
double LogMergeOfParts(const StateEvaluation& s, const std::vector<int>& part_a,
                       const std::vector<int>& part_b, int merged_class,
                       const ClassConfusionModel& model, const MoveOptions& options,
                       const MoveProbabilities& probabilities) {
  return LogMergeProbability(s, s.state.BlockOf(part_a.front()), s.state.BlockOf(part_b.front()),
                             merged_class, model, options, probabilities);
}

// log q of splitting the object that holds `part_a` and `part_b` in `s` into
// the two with classes `class_a` and `class_b`; whichever holds the earliest
// track is the split's first part (Algorithm 6 step 4).
double LogSplitIntoParts(const StateEvaluation& s, const std::vector<int>& part_a,
                         const std::vector<int>& part_b, int class_a, int class_b,
                         const ClassConfusionModel& model, const MoveOptions& options,
                         const MoveProbabilities& probabilities) {
  const bool a_first = part_a.front() < part_b.front();
  return LogSplitProbability(s, s.state.BlockOf(part_a.front()), a_first ? part_a : part_b,
                             a_first ? part_b : part_a, a_first ? class_a : class_b,
                             a_first ? class_b : class_a, model, options, probabilities);
}

}  // namespace

bool NormaliseLog(std::vector<double>* log_w) {
  const double total = LogSumExp(*log_w);
  if (total == kNegInf) return false;
  for (double& x : *log_w) x -= total;
  return true;
}

int SampleLog(const std::vector<double>& log_p, Rng& rng) {
  double u = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  int last = -1;
  for (size_t i = 0; i < log_p.size(); ++i) {
    if (log_p[i] == kNegInf) continue;
    last = static_cast<int>(i);
    u -= std::exp(log_p[i]);
    if (u < 0) return last;
  }
  return last;  // rounding: the last possible index
}

const char* MoveName(MoveType type) {
  switch (type) {
    case MoveType::kMerge:
      return "merge";
    case MoveType::kSplit:
      return "split";
    case MoveType::kSwitch:
      return "switch";
    case MoveType::kReassign:
      return "reassign";
  }
  return "?";
}

bool MoveOptions::Validate(std::string* why) const {
  auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (!(merge_distance_m > 0)) return fail("the merge distance threshold must be > 0 m");
  if (!(merge_sigma_m > 0) || std::isinf(merge_sigma_m)) return fail("sigma_E must be > 0 m");
  if (!(class_mismatch_penalty >= 1)) return fail("the class-mismatch penalty must be >= 1");
  if (!(merge_count_smoothing >= 0) || std::isinf(merge_count_smoothing))
    return fail("the merge count smoothing must be >= 0");
  if (!(reassign_sigma_m > 0) || std::isinf(reassign_sigma_m))
    return fail("sigma_R of the reassign move must be > 0 m");
  if (!(reassign_focus >= 0) || std::isinf(reassign_focus))
    return fail("the reassign move's focus on misfitting tracks must be >= 0 and finite");
  if (!(class_proposal_uniform >= 0) || !(class_proposal_uniform < 1))
    return fail("the uniform share of the class proposal must be in [0, 1)");
  return true;
}

double LogMergeProbability(const StateEvaluation& s, int a, int b, int merged_class,
                           const ClassConfusionModel& model, const MoveOptions& options,
                           const MoveProbabilities& probabilities) {
  std::vector<double> log_d, log_ea, log_eb;
  if (!MergeFirstWeights(s, options, &log_d)) return kNegInf;
  // #17/#40: both orders (a, b) and (b, a) give the same merged state.
  const double order_ab =
      MergePartnerWeights(s, a, options, &log_ea) ? log_d[a] + log_ea[b] : kNegInf;
  const double order_ba =
      MergePartnerWeights(s, b, options, &log_eb) ? log_d[b] + log_eb[a] : kNegInf;
  const std::vector<int> merged = Union(s.state.blocks[a], s.state.blocks[b]);
  return LogOf(probabilities.merge) + LogSumExp({order_ab, order_ba}) +
         LogClassProposal(model, merged, options)[merged_class];
}

double LogSplitProbability(const StateEvaluation& s, int block, const std::vector<int>& part_first,
                           const std::vector<int>& part_second, int class_first, int class_second,
                           const ClassConfusionModel& model, const MoveOptions& options,
                           const MoveProbabilities& probabilities) {
  std::vector<double> log_w;
  if (!SplitWeights(s, &log_w)) return kNegInf;
  const size_t n = s.state.blocks[block].size();
  return LogOf(probabilities.split) + log_w[block] +
         LogPartitionProbability(n, part_second.size(), options.split_sampler) +
         LogClassProposal(model, part_first, options)[class_first] +
         LogClassProposal(model, part_second, options)[class_second];
}

double LogSwitchProbability(const StateEvaluation& s, int block, int new_class,
                            const ClassConfusionModel& model, const MoveOptions& options,
                            const MoveProbabilities& probabilities) {
  std::vector<double> log_p = SwitchWeights(s, model);
  if (!NormaliseLog(&log_p)) return kNegInf;
  const std::vector<double> log_q = SwitchClassProposal(s, block, model, options);
  if (log_q.empty()) return kNegInf;
  return LogOf(probabilities.switch_class) + log_p[block] + log_q[new_class];
}

double LogReassignProbability(const StateEvaluation& s, int track, int target_block,
                              int joined_class, int rest_class, const ClassConfusionModel& model,
                              const MoveOptions& options, const MoveProbabilities& probabilities) {
  const int from = s.state.BlockOf(track);
  std::vector<double> log_w;
  if (from < 0 || target_block == from || !ReassignWeights(s, from, track, model, options, &log_w))
    return kNegInf;
  const std::vector<int> joined =
      target_block >= 0 ? Union(s.state.blocks[target_block], {track}) : std::vector<int>{track};
  std::vector<int> rest;
  for (int t : s.state.blocks[from])
    if (t != track) rest.push_back(t);
  double log_q = LogOf(probabilities.reassign) + ReassignTrackWeights(s, model, options)[track] +
                 (target_block >= 0 ? log_w[target_block] : log_w.back()) +
                 LogClassProposal(model, joined, options)[joined_class];
  if (!rest.empty()) log_q += LogClassProposal(model, rest, options)[rest_class];
  return log_q;
}

Proposal ProposeMove(const StateEvaluation& current, const ClassConfusionModel& model,
                     const MoveOptions& options, const MoveProbabilities& probabilities, Rng& rng) {
  const double u = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  if (u < probabilities.merge) return ProposeMerge(current, model, options, probabilities, rng);
  if (u < probabilities.merge + probabilities.split)
    return ProposeSplit(current, model, options, probabilities, rng);
  if (u < probabilities.merge + probabilities.split + probabilities.switch_class ||
      !(probabilities.reassign > 0))
    return ProposeSwitch(current, model, options, probabilities, rng);
  return ProposeReassign(current, model, options, probabilities, rng);
}

double LogReverseProbability(const Proposal& p, const StateEvaluation& proposed,
                             const ClassConfusionModel& model, const MoveOptions& options,
                             const MoveProbabilities& probabilities) {
  switch (p.type) {
    case MoveType::kMerge:  // the split that undoes it
      return LogSplitIntoParts(proposed, p.part_a, p.part_b, p.old_class_a, p.old_class_b, model,
                               options, probabilities);
    case MoveType::kSplit:
      return LogMergeOfParts(proposed, p.part_a, p.part_b, p.old_class_a, model, options,
                             probabilities);
    case MoveType::kSwitch:
      return LogSwitchProbability(proposed, proposed.state.BlockOf(p.track), p.old_class_a, model,
                                  options, probabilities);
    case MoveType::kReassign:  // back to what its object kept (or alone), at the old classes
      return LogReassignProbability(
          proposed, p.track, p.part_a.empty() ? -1 : proposed.state.BlockOf(p.part_a.front()),
          p.old_class_a, p.old_class_b, model, options, probabilities);
  }
  return kNegInf;
}

double LogForwardProbability(const Proposal& p, const StateEvaluation& from,
                             const ClassConfusionModel& model, const MoveOptions& options,
                             const MoveProbabilities& probabilities) {
  const AssociationState& to = p.state;
  auto new_class = [&to](int track) { return to.classes[to.BlockOf(track)]; };
  switch (p.type) {
    case MoveType::kMerge:
      return LogMergeOfParts(from, p.part_a, p.part_b, new_class(p.part_a.front()), model, options,
                             probabilities);
    case MoveType::kSplit:
      return LogSplitIntoParts(from, p.part_a, p.part_b, new_class(p.part_a.front()),
                               new_class(p.part_b.front()), model, options, probabilities);
    case MoveType::kSwitch:
      return LogSwitchProbability(from, from.state.BlockOf(p.track), new_class(p.track), model,
                                  options, probabilities);
    case MoveType::kReassign:
      return LogReassignProbability(
          from, p.track, p.part_b.empty() ? -1 : from.state.BlockOf(p.part_b.front()),
          new_class(p.track), p.part_a.empty() ? 0 : new_class(p.part_a.front()), model, options,
          probabilities);
  }
  return kNegInf;
}

}  // namespace oslam
