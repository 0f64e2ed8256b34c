#include "association/sampler.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <thread>
#include <unordered_map>

#include "core/error.h"
#include "core/text.h"
#include "slam/geometric_slam.h"

namespace oslam {
namespace {

// Why the start state (every track its own object) has no valid target:
// the solver's reason when there was a solve.
std::string WhyInvalid(const StateEvaluation* start, size_t objects) {
  std::string why = "the start state (" + std::to_string(objects) +
                    " tracks, each its own object) could not be evaluated";
  if (!start || !start->solution) return why;
  const GeometricSlamResult& solution = *start->solution;
  if (!solution.summary.IsUsable())
    return why + ": the solver failed (" + solution.summary.message + ")";
  return why + ": its evidence is not finite (the solved system is not positive definite)";
}

bool ValidProbabilities(const MoveProbabilities& p) {
  return p.merge >= 0 && p.split >= 0 && p.switch_class >= 0 && p.reassign >= 0 &&
         std::abs(p.merge + p.split + p.switch_class + p.reassign - 1.0) < 1e-9;
}

// One random stream per chain, derived from the seed and the chain index.
Rng ChainRng(unsigned long seed, int chain) {
  std::seed_seq sequence{static_cast<unsigned>(seed), static_cast<unsigned>(seed >> 32),
                         static_cast<unsigned>(chain), 0x05a1u};
  return Rng(sequence);
}

// Delayed acceptance's first stage for a move from `from` to the state that
// `approximate` stands for: min(0, log alpha1), 0 (accept) when the evaluator
// has no approximation or the ratio is NaN. `log_alpha1(approximate,
// tempered)` completes the ratio from its first term, tempered = beta
// (log pi~(to) - log pi(from)), with the proposal probabilities.
template <typename LogAlpha1>
double LogScreenAcceptance(const EvaluationPtr& approximate, const StateEvaluation& from,
                           double beta, const LogAlpha1& log_alpha1) {
  if (!approximate || !approximate->valid) return 0.0;
  const double log_alpha =
      log_alpha1(*approximate, beta * (approximate->log_target - from.log_target));
  return std::isnan(log_alpha) ? 0.0 : std::min(0.0, log_alpha);
}

std::vector<AssociationState> TrackChanges(const StateEvaluation& current, int track,
                                           const ClassConfusionModel& model, double radius_m);

// How far from its object the sweeps and the track scan look for objects a
// track may join: 3 sigma_R.
double TrackChangeRadiusM(const MoveOptions& moves) {
  return 3.0 * moves.reassign_sigma_m;
}

// Where a track scan may put a track from a state: the state itself first,
// then its TrackChanges, with log probabilities in proportion to beta
// (approximate log target - the state's), minus infinity where the evaluator
// has no approximation.
struct TrackDraw {
  std::vector<AssociationState> states;
  std::vector<double> log_p;
};

// The draws from one evaluated state, by track.
struct TrackDrawCache {
  EvaluationPtr from;
  std::unordered_map<int, TrackDraw> by_track;
};

// One MC3 chain: its state, temperature, random stream, statistics and evaluator.
struct Chain {
  EvaluationPtr state;
  double beta = 1.0;
  Rng rng;
  std::array<MoveStatistics, kNumMoveTypes> stats{};
  StateEvaluator* evaluator = nullptr;
  // The tracks it updates one by one after its steps in each iteration
  // (SamplerOptions::track_scan_max; the cold chain only) and how that went.
  std::vector<int> scan_tracks;
  MoveStatistics scan{};
  // The track scan's draws from `state`, by track (computed once per state:
  // most updates leave the state as it was).
  TrackDrawCache draws;
};

// A chain after a block of iterations: what going back to it needs.
struct ChainCheckpoint {
  EvaluationPtr state;
  Rng rng;
  std::array<MoveStatistics, kNumMoveTypes> stats{};
  MoveStatistics scan{};
  size_t mark = 0;                         // the evaluator's
  std::vector<EvaluationPtr> cold_states;  // chain 0: its state after each iteration
};

TrackDraw TrackDrawFrom(const EvaluationPtr& at, int track, double beta, double radius_m,
                        StateEvaluator& evaluator, const ClassConfusionModel& model) {
  TrackDraw draw;
  draw.states.push_back(at->state);
  draw.log_p.push_back(0.0);
  for (AssociationState& change : TrackChanges(*at, track, model, radius_m)) {
    const EvaluationPtr approximate = evaluator.Approximate(change, *at);
    const bool usable = approximate && approximate->valid && std::isfinite(approximate->log_target);
    draw.log_p.push_back(usable ? beta * (approximate->log_target - at->log_target)
                                : -std::numeric_limits<double>::infinity());
    draw.states.push_back(std::move(change));
  }
  NormaliseLog(&draw.log_p);  // never all zero: the state itself has weight 1
  return draw;
}

// One update of `track` (beyond the thesis, docs/method.md §9.4): the track
// stays or makes one of its TrackChanges, drawn in proportion to
// exp(beta x the evaluator's approximate target), and Metropolis-Hastings
// with the exact target corrects the draw, the reverse draw's probability
// taken from the proposed state. Where the approximation is close this is a
// Gibbs update of the track's place; a wrong one only costs acceptance.
EvaluationPtr TrackScanStep(const EvaluationPtr& current, int track, double beta, double radius_m,
                            StateEvaluator& evaluator, const ClassConfusionModel& model, Rng& rng,
                            TrackDrawCache* cache, MoveStatistics* stats) {
  ++stats->proposed;
  if (current->state.BlockOf(track) < 0) {
    ++stats->self_transitions;
    return current;
  }
  const auto start = std::chrono::steady_clock::now();
  if (cache->from != current) *cache = {current, {}};
  auto cached = cache->by_track.find(track);
  if (cached == cache->by_track.end())
    cached = cache->by_track
                 .emplace(track, TrackDrawFrom(current, track, beta, radius_m, evaluator, model))
                 .first;
  const TrackDraw& forward = cached->second;
  // Both uniforms are drawn for every update, so the stream does not depend on outcomes.
  const int chosen = SampleLog(forward.log_p, rng);
  const double log_u = std::log(std::uniform_real_distribution<double>(0.0, 1.0)(rng));
  if (chosen <= 0) {
    ++stats->self_transitions;
    stats->time_s += SecondsSince(start);
    return current;
  }
  const size_t hits_before = evaluator.num_cache_hits();
  const EvaluationPtr proposed = evaluator.Evaluate(forward.states[chosen], current.get());
  stats->cache_hits += static_cast<long>(evaluator.num_cache_hits() - hits_before);
  if (!proposed || !proposed->valid) {
    stats->time_s += SecondsSince(start);
    return current;
  }
  TrackDraw reverse = TrackDrawFrom(proposed, track, beta, radius_m, evaluator, model);
  const auto back = std::find(reverse.states.begin(), reverse.states.end(), current->state);
  const double log_reverse = back == reverse.states.end()
                                 ? -std::numeric_limits<double>::infinity()
                                 : reverse.log_p[back - reverse.states.begin()];
  const double log_alpha =
      beta * (proposed->log_target - current->log_target) + log_reverse - forward.log_p[chosen];
  stats->time_s += SecondsSince(start);
  if (!std::isfinite(log_reverse) || !(log_u < std::min(0.0, log_alpha))) return current;
  ++stats->accepted;
  *cache = {proposed, {}};
  cache->by_track.emplace(track, std::move(reverse));
  return proposed;
}

// The iterations of a block: chains may swap after each block of
// `swap_every` iterations (the last block may be shorter).
struct BlockIterations {
  int first = 1, last = 1;
};

BlockIterations IterationsOf(int block, const SamplerOptions& options) {
  const int first = 1 + block * options.swap_every;
  return {first, std::min(options.num_iterations, first + options.swap_every - 1)};
}

int NumBlocks(const SamplerOptions& options) {
  return (options.num_iterations + options.swap_every - 1) / options.swap_every;
}

// Steps `chain` through the iterations of `block`; `cold`: the checkpoint
// keeps the state after each iteration, for the record.
ChainCheckpoint StepBlock(Chain* chain, bool cold, int block, const ClassConfusionModel& model,
                          const SamplerOptions& options) {
  const BlockIterations iterations = IterationsOf(block, options);
  ChainCheckpoint done;
  StepRule sample;
  sample.beta = chain->beta;
  sample.delayed_acceptance = options.delayed_acceptance;
  // The cold chain may take several steps per iteration (thinning): any
  // number of steps between swaps keeps its target invariant.
  const int steps = cold ? options.cold_chain_steps : 1;
  const double radius_m = TrackChangeRadiusM(options.moves);
  for (int t = iterations.first; t <= iterations.last; ++t) {
    for (int k = 0; k < steps; ++k)
      chain->state = MetropolisStep(chain->state, sample, *chain->evaluator, model, options.moves,
                                    options.sampling_moves, chain->rng, &chain->stats);
    for (int track : chain->scan_tracks)
      chain->state = TrackScanStep(chain->state, track, chain->beta, radius_m, *chain->evaluator,
                                   model, chain->rng, &chain->draws, &chain->scan);
    if (cold) done.cold_states.push_back(chain->state);
  }
  done.state = chain->state;
  done.rng = chain->rng;
  done.stats = chain->stats;
  done.scan = chain->scan;
  done.mark = chain->evaluator->Mark();
  return done;
}

// Steps the chains block by block and hands each block's checkpoints to the
// swap decisions, in order. With threads every chain runs in its own, up to
// `depth` blocks ahead of the decisions (speculation); a chain that an
// accepted swap reaches is held between blocks while the caller sends it
// back to its checkpoint at that swap, and goes on from the next block, so
// the result is the one of stepping the chains one after another. Without
// threads the chains step one after another when a block is asked for.
class ChainStepper {
 public:
  ChainStepper(std::vector<Chain>* chains, const ClassConfusionModel& model,
               const SamplerOptions& options, bool threaded, int depth)
      : chains_(*chains),
        model_(model),
        options_(options),
        num_blocks_(NumBlocks(options)),
        depth_(depth),
        published_(chains_.size()),
        next_block_(chains_.size(), 0),
        hold_(chains_.size(), 0),
        held_(chains_.size(), 0),
        release_pending_(chains_.size(), 0),
        release_mark_(chains_.size(), 0) {
    if (threaded)
      for (size_t i = 0; i < chains_.size(); ++i)
        threads_.emplace_back(&ChainStepper::ChainThread, this, i);
  }
  ~ChainStepper() { Stop(); }
  ChainStepper(const ChainStepper&) = delete;
  ChainStepper& operator=(const ChainStepper&) = delete;

  int num_blocks() const { return num_blocks_; }

  // The chains' checkpoints after `block`, the block after the last one
  // decided. Rethrows what a chain's thread threw.
  std::vector<ChainCheckpoint> Next(int block) {
    std::vector<ChainCheckpoint> at(chains_.size());
    if (threads_.empty()) {
      for (size_t i = 0; i < chains_.size(); ++i)
        at[i] = StepBlock(&chains_[i], i == 0, block, model_, options_);
      return at;
    }
    std::unique_lock<std::mutex> lock(mutex_);
    to_caller_.wait(lock, [&] {
      if (failure_) return true;
      for (const auto& queue : published_)
        if (queue.empty()) return false;
      return true;
    });
    if (failure_) std::rethrow_exception(failure_);
    for (size_t i = 0; i < chains_.size(); ++i) {
      at[i] = std::move(published_[i].front());
      published_[i].pop_front();
    }
    return at;
  }

  // Returns once the `swapped` chains are between blocks, so that the caller
  // may send them back. Rethrows what a chain's thread threw.
  void Hold(const std::vector<char>& swapped) {
    if (threads_.empty()) return;
    std::unique_lock<std::mutex> lock(mutex_);
    for (size_t i = 0; i < chains_.size(); ++i) hold_[i] = swapped[i];
    to_chains_.notify_all();
    to_caller_.wait(lock, [&] {
      if (failure_) return true;
      for (size_t i = 0; i < chains_.size(); ++i)
        if (swapped[i] && !held_[i]) return false;
      return true;
    });
    if (failure_) std::rethrow_exception(failure_);
  }

  // The swaps after `block` are decided: the swapped chains (sent back by
  // the caller) go on from the next block, dropping what they did ahead;
  // the others' evaluators may forget what going back before `at` needs.
  void Decided(int block, const std::vector<char>& swapped,
               const std::vector<ChainCheckpoint>& at) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (size_t i = 0; i < chains_.size(); ++i) {
        if (swapped[i]) {
          published_[i].clear();
          next_block_[i] = block + 1;
          hold_[i] = held_[i] = 0;
        } else if (!threads_.empty()) {  // the evaluator is the chain's thread's
          release_pending_[i] = 1;
          release_mark_[i] = at[i].mark;
        } else {
          chains_[i].evaluator->Release(at[i].mark);
        }
      }
      decided_ = block + 1;
    }
    to_chains_.notify_all();
  }

  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    to_chains_.notify_all();
    for (auto& thread : threads_)
      if (thread.joinable()) thread.join();
  }

 private:
  // Chain i's thread: steps the next block when it is at most depth_ ahead
  // of the decisions, parks while held.
  void ChainThread(size_t i) {
    for (;;) {
      int block;
      size_t release = 0;
      bool do_release = false;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
          if (stop_) return;
          if (hold_[i]) {
            if (!held_[i]) to_caller_.notify_one();
            held_[i] = 1;
          } else if (next_block_[i] < num_blocks_ && next_block_[i] <= decided_ + depth_) {
            break;
          }
          to_chains_.wait(lock);
        }
        block = next_block_[i];
        do_release = release_pending_[i];
        release_pending_[i] = 0;
        release = release_mark_[i];
      }
      ChainCheckpoint done;
      try {
        if (do_release) chains_[i].evaluator->Release(release);
        done = StepBlock(&chains_[i], i == 0, block, model_, options_);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!failure_) failure_ = std::current_exception();
        to_caller_.notify_one();
        return;
      }
      std::lock_guard<std::mutex> lock(mutex_);
      published_[i].push_back(std::move(done));
      ++next_block_[i];
      to_caller_.notify_one();
    }
  }

  std::vector<Chain>& chains_;
  const ClassConfusionModel& model_;
  const SamplerOptions& options_;
  const int num_blocks_, depth_;
  std::mutex mutex_;
  // Chains' threads wait for decisions (to_chains_), the caller for
  // checkpoints and held chains (to_caller_): a change wakes only who waits
  // for it.
  std::condition_variable to_chains_, to_caller_;
  // Guarded by mutex_: the chains' checkpoints not yet taken, the block each
  // chain steps next, held chains, and marks a chain's thread is to release.
  std::vector<std::deque<ChainCheckpoint>> published_;
  std::vector<int> next_block_;
  std::vector<char> hold_, held_, release_pending_;
  std::vector<size_t> release_mark_;
  int decided_ = 0;  // blocks whose swaps are decided
  bool stop_ = false;
  std::exception_ptr failure_;  // thrown in a chain's thread, rethrown by the caller
  std::vector<std::thread> threads_;
};

// Swaps of adjacent chains after a block, hottest pair first (5.3), on the
// chains' `states` then: whole states move. Returns each chain that received
// a state, with that state, in the order the swaps were accepted.
std::vector<std::pair<int, EvaluationPtr>> DecideSwaps(const std::vector<Chain>& chains,
                                                       std::vector<EvaluationPtr>* states,
                                                       Rng* swap_rng, SamplerSummary* summary) {
  std::vector<EvaluationPtr>& s = *states;
  std::vector<std::pair<int, EvaluationPtr>> learnt;
  for (int i = static_cast<int>(chains.size()) - 1; i >= 1; --i) {
    ++summary->swaps_proposed;
    const double log_alpha =
        (chains[i - 1].beta - chains[i].beta) * (s[i]->log_target - s[i - 1]->log_target);
    const double u = std::uniform_real_distribution<double>(0.0, 1.0)(*swap_rng);
    if (std::log(u) < std::min(0.0, log_alpha)) {
      std::swap(s[i], s[i - 1]);
      learnt.emplace_back(i, s[i]);
      learnt.emplace_back(i - 1, s[i - 1]);
      ++summary->swaps_accepted;
    }
  }
  return learnt;
}

// Sends a chain that an accepted swap reached back to its checkpoint `at`
// at that swap (its evaluator rolls back), with the state it received.
// Returns the solves undone.
size_t SendBack(Chain* chain, const ChainCheckpoint& at, const EvaluationPtr& received) {
  const size_t solves = chain->evaluator->num_solves();
  chain->evaluator->RollBack(at.mark);
  const size_t undone = solves - chain->evaluator->num_solves();
  chain->evaluator->Release(at.mark);
  chain->state = received;
  chain->rng = at.rng;
  chain->stats = at.stats;
  chain->scan = at.scan;
  return undone;
}

// The cold chain's record: its trace, the best state, and after the burn-in
// the samples. These get their covariances from an evaluator of their own,
// so that the chains never wait for it; a state is completed once.
class ColdChainRecorder {
 public:
  ColdChainRecorder(const EvaluatorFactory& factory, int burn_in, SamplerResult* result)
      : factory_(factory), burn_in_(burn_in), result_(*result) {}

  void Record(int t, const EvaluationPtr& cold) {
    result_.summary.cold_trace.push_back(cold->log_target);
    if (cold->log_target > result_.best->log_target) result_.best = cold;
    if (t <= burn_in_) return;
    EvaluationPtr& done = completed_[cold->state];
    if (!done) {
      if (!completer_) completer_ = factory_();
      done = completer_->Complete(cold);
    }
    result_.samples.push_back(done);
  }
  size_t num_solves() const { return completer_ ? completer_->num_solves() : 0; }

 private:
  const EvaluatorFactory& factory_;
  const int burn_in_;
  SamplerResult& result_;
  std::unique_ptr<StateEvaluator> completer_;
  std::unordered_map<AssociationState, EvaluationPtr, AssociationStateHash> completed_;
};

}  // namespace

bool SamplerOptions::Validate(std::string* why) const {
  auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (hill_climb_steps < 0) return fail("the hill-climbing steps must be >= 0");
  if (hill_climb_patience < 0) return fail("the hill-climbing patience must be >= 0");
  if (hill_climb_max_steps < hill_climb_steps)
    return fail("hill_climb_max_steps must be >= hill_climb_steps");
  if (refine_every < 1) return fail("the refinement interval K_NL must be >= 1");
  if (hill_climb_sweeps < 0) return fail("hill_climb_sweeps must be >= 0");
  if (!(hill_climb_screen_nats >= 0))
    return fail("the hill-climbing screen margin must be >= 0 nats (inf: solve every proposal)");
  if (!ValidProbabilities(hill_climb_moves) || !ValidProbabilities(sampling_moves))
    return fail("move probabilities must be >= 0 and sum to 1");
  if (num_chains < 1) return fail("at least one chain is needed");
  if (cold_chain_steps < 1) return fail("the cold chain's steps per iteration must be >= 1");
  if (swap_every < 1) return fail("chains swap every >= 1 iterations");
  if (speculation_depth < 0) return fail("the speculation depth must be >= 0 swap intervals");
  if (!(delta_temperature >= 0) || std::isinf(delta_temperature))
    return fail("the temperature step dT must be >= 0");
  if (num_iterations < 1) return fail("at least one iteration is needed");
  if (track_scan_max < 0) return fail("the number of scanned tracks must be >= 0");
  if (!(track_scan_nats >= 0)) return fail("the track scan's margin must be >= 0 nats");
  if (burn_in < 0 || burn_in >= num_iterations)
    return fail("the burn-in must be >= 0 and below the number of iterations");
  return moves.Validate(why);
}

EvaluationPtr MetropolisStep(const EvaluationPtr& current, const StepRule& rule,
                             StateEvaluator& evaluator, const ClassConfusionModel& model,
                             const MoveOptions& options, const MoveProbabilities& probabilities,
                             Rng& rng, std::array<MoveStatistics, kNumMoveTypes>* stats) {
  const double beta = rule.beta;
  const bool greedy = rule.greedy;
  const Proposal proposal = ProposeMove(*current, model, options, probabilities, rng);
  MoveStatistics& stat = (*stats)[static_cast<int>(proposal.type)];
  ++stat.proposed;
  // The uniforms are drawn for every proposal so the stream does not depend on outcomes.
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double log_u = std::log(uniform(rng));
  const bool screen = rule.delayed_acceptance && !greedy;
  const double log_u_screen = screen ? std::log(uniform(rng)) : 0.0;
  if (proposal.self_transition) {
    ++stat.self_transitions;
    return current;
  }
  const auto start = std::chrono::steady_clock::now();
  if (greedy && std::isfinite(rule.greedy_screen_nats)) {
    const EvaluationPtr approximate = evaluator.Approximate(proposal.state, *current);
    if (approximate && approximate->valid &&
        approximate->log_target - current->log_target < -rule.greedy_screen_nats) {
      ++stat.screened_out;
      stat.time_s += SecondsSince(start);
      return current;
    }
  }
  // Delayed acceptance (Christen & Fox 2005). Stage 1 accepts x -> y with
  //   alpha1(x, y) = min(1, pi~(y)^beta q(x | y~) / (pi(x)^beta q(y | x))),
  // y~ = the evaluator's approximation of y made from x; 1 where it has none.
  double log_screen_forward = 0.0;
  if (screen) {
    log_screen_forward = LogScreenAcceptance(
        evaluator.Approximate(proposal.state, *current), *current, beta,
        [&](const StateEvaluation& approximate, double tempered) {
          return tempered +
                 LogReverseProbability(proposal, approximate, model, options, probabilities) -
                 proposal.log_q_forward;
        });
    if (log_u_screen >= log_screen_forward) {
      ++stat.screened_out;
      stat.time_s += SecondsSince(start);
      return current;
    }
  }
  const size_t hits_before = evaluator.num_cache_hits();
  EvaluationPtr proposed = evaluator.Evaluate(proposal.state, current.get());
  stat.cache_hits += static_cast<long>(evaluator.num_cache_hits() - hits_before);
  if (!proposed || !proposed->valid) {
    stat.time_s += SecondsSince(start);
    return current;
  }
  const double delta = proposed->log_target - current->log_target;
  bool accept;
  if (greedy) {
    accept = delta > 0;
  } else {
    const double log_reverse =
        LogReverseProbability(proposal, *proposed, model, options, probabilities);
    double log_alpha = beta * delta + log_reverse - proposal.log_q_forward;
    if (screen) {
      // Stage 2: times alpha1(y, x) / alpha1(x, y), the reverse move's
      // screen as the sampler would compute it standing at y.
      const double log_screen_reverse = LogScreenAcceptance(
          evaluator.Approximate(current->state, *proposed), *proposed, beta,
          [&](const StateEvaluation& approximate, double tempered) {
            return tempered - log_reverse +
                   LogForwardProbability(proposal, approximate, model, options, probabilities);
          });
      log_alpha += log_screen_reverse - log_screen_forward;
    }
    accept = std::isfinite(log_reverse) && log_u < std::min(0.0, log_alpha);
  }
  stat.time_s += SecondsSince(start);
  if (!accept) return current;
  ++stat.accepted;
  return proposed;
}

double EffectiveSampleSize(const std::vector<double>& x) {
  const size_t n = x.size();
  if (n < 4) return static_cast<double>(n);
  double mean = 0;
  for (double v : x) mean += v;
  mean /= n;
  auto autocovariance = [&](size_t lag) {
    double s = 0;
    for (size_t i = 0; i + lag < n; ++i) s += (x[i] - mean) * (x[i + lag] - mean);
    return s / n;
  };
  const double c0 = autocovariance(0);
  if (!(c0 > 0)) return static_cast<double>(n);
  // Geyer's initial positive sequence: sum pairs of autocorrelations while positive.
  double sum = 0;
  for (size_t lag = 1; lag + 1 < n; lag += 2) {
    const double pair = (autocovariance(lag) + autocovariance(lag + 1)) / c0;
    if (pair <= 0) break;
    sum += pair;
  }
  return n / (1.0 + 2.0 * sum);
}

Sampler::Sampler(const ClassConfusionModel& model, EvaluatorFactory factory,
                 const SamplerOptions& options)
    : model_(model), factory_(std::move(factory)), options_(options) {}

SamplerResult Sampler::Run(const AssociationState& start, const ProgressCallback& progress) {
  std::string why;
  if (!options_.Validate(&why)) throw Error("sampler options: " + why);
  std::vector<std::unique_ptr<StateEvaluator>> evaluators;
  std::vector<Rng> rngs;
  for (int i = 0; i < options_.num_chains; ++i) {
    evaluators.push_back(factory_());
    rngs.push_back(ChainRng(options_.seed, i));
  }
  SamplerResult result;
  SamplerSummary& summary = result.summary;
  // The cold chain climbs with its own evaluator and random stream.
  result.hill_climbed = HillClimb(start, evaluators[0].get(), &rngs[0], &summary, progress);
  summary.scan_tracks = ContestedTracks(result.hill_climbed, evaluators[0].get());
  SampleChains(evaluators, rngs, &result, progress);
  for (const auto& evaluator : evaluators) {
    summary.num_solves += evaluator->num_solves();
    summary.num_cache_hits += evaluator->num_cache_hits();
  }
  summary.effective_sample_size = EffectiveSampleSize(
      std::vector<double>(summary.cold_trace.begin() + options_.burn_in, summary.cold_trace.end()));
  summary.message = "ok";
  return result;
}

EvaluationPtr Sampler::HillClimb(const AssociationState& start_state, StateEvaluator* evaluator,
                                 Rng* rng, SamplerSummary* summary,
                                 const ProgressCallback& progress) const {
  // Algorithm 9 steps 3-4: full optimisation, then greedy moves, refining
  // every K_NL steps (and replacing the cached value, docs/method.md §9.3).
  const auto clock = std::chrono::steady_clock::now();
  AssociationState start = start_state;
  start.Canonicalize();
  EvaluationPtr current = evaluator->Refine(start, nullptr);
  if (!current || !current->valid) throw Error(WhyInvalid(current.get(), start.blocks.size()));
  summary->initial_log_target = current->log_target;
  int last_accepted = 0, step = 0;
  auto go_on = [&] {
    if (step < options_.hill_climb_steps) return true;
    return options_.hill_climb_steps > 0 && options_.hill_climb_patience > 0 &&
           step < options_.hill_climb_max_steps &&
           step - last_accepted < options_.hill_climb_patience;
  };
  StepRule climb;
  climb.greedy = true;
  climb.greedy_screen_nats = options_.hill_climb_screen_nats;
  while (go_on()) {
    ++step;
    const EvaluationPtr before = current;
    current = MetropolisStep(current, climb, *evaluator, model_, options_.moves,
                             options_.hill_climb_moves, *rng, &summary->hill_climb);
    if (current != before) last_accepted = step;
    const bool last = !go_on();
    if (step % options_.refine_every == 0 || last) {
      EvaluationPtr refined = evaluator->Refine(current->state, current.get());
      if (refined && refined->valid) current = refined;
    }
    summary->hill_climb_trace.push_back(current->log_target);
    if (progress)
      progress("hill climbing", std::min(step, options_.hill_climb_steps),
               options_.hill_climb_steps);
  }
  summary->hill_climb_steps = step;
  current = Sweep(current, evaluator, summary);
  summary->hill_climbed_log_target = current->log_target;
  summary->hill_climb_time_s = SecondsSince(clock);
  return current;
}

namespace {

// The class the detections of `block` speak for most (the class proposal's
// data-driven mode).
int LikeliestClass(const ClassConfusionModel& model, const std::vector<int>& block) {
  const std::vector<double> log_q = model.ClassLogProposal(block);
  return static_cast<int>(std::max_element(log_q.begin(), log_q.end()) - log_q.begin());
}

// The states one change away from `current` that a sweep tries for `track`:
// into every other object within `radius_m` of its own, or, when it has
// company, alone (at its object's class or its detections' likeliest). The
// object it joins and the one it leaves each keep their class or take the
// one their tracks' detections speak for most: a wrong track can hold its
// object at a class that only fits with it.
std::vector<AssociationState> TrackChanges(const StateEvaluation& current, int track,
                                           const ClassConfusionModel& model, double radius_m) {
  const AssociationState& state = current.state;
  const int from = state.BlockOf(track);
  std::vector<int> rest;
  for (int t : state.blocks[from])
    if (t != track) rest.push_back(t);
  std::vector<int> rest_classes;
  if (!rest.empty()) {
    rest_classes = {state.classes[from]};
    const int likeliest = LikeliestClass(model, rest);
    if (likeliest != rest_classes.front()) rest_classes.push_back(likeliest);
  }
  std::vector<AssociationState> changes;
  // Into `target` (-1: alone) at `joined_class`, what it leaves at each of rest_classes.
  auto add = [&](int target, int joined_class) {
    AssociationState moved = state.WithTrackMoved(track, target, joined_class);
    if (rest.empty()) {
      changes.push_back(std::move(moved));
      return;
    }
    for (int rest_class : rest_classes) {
      moved.classes[moved.BlockOf(rest.front())] = rest_class;
      changes.push_back(moved);
    }
  };
  // The class the detections of `tracks` plus `track` speak for most.
  const auto likeliest_with_track = [&](std::vector<int> tracks) {
    tracks.insert(std::upper_bound(tracks.begin(), tracks.end(), track), track);
    return LikeliestClass(model, tracks);
  };
  for (size_t k = 0; k < state.blocks.size(); ++k) {
    if (static_cast<int>(k) == from ||
        !((current.locations[k] - current.locations[from]).norm() < radius_m))
      continue;
    const int target = static_cast<int>(k);
    add(target, state.classes[k]);
    const int likeliest = likeliest_with_track(state.blocks[k]);
    if (likeliest != state.classes[k]) add(target, likeliest);
  }
  if (!rest.empty()) {
    // The class sweep tries the other classes of a track alone.
    add(-1, state.classes[from]);
    const int likeliest = likeliest_with_track({});
    if (likeliest != state.classes[from]) add(-1, likeliest);
  } else {
    // A track alone: its object at every other class, so that a scanned
    // track's class is drawn as its place is (a one-track object's class
    // otherwise changes only by the rare switch move that picks it).
    for (int c = 0; c < model.num_classes(); ++c)
      if (c != state.classes[from]) add(-1, c);
  }
  return changes;
}

std::vector<AssociationState> ClassChanges(const AssociationState& state, int block,
                                           int num_classes) {
  std::vector<AssociationState> changes;
  for (int c = 0; c < num_classes; ++c) {
    if (c == state.classes[block]) continue;
    changes.push_back(state);
    changes.back().classes[block] = c;
  }
  return changes;
}

}  // namespace

EvaluationPtr Sampler::Sweep(EvaluationPtr current, StateEvaluator* evaluator,
                             SamplerSummary* summary) const {
  // Each candidate is ranked by the evaluator's approximation (poses held);
  // the best is solved, and taken when the solve raises the target. A change
  // the approximation puts slightly below the current state is still solved,
  // since the poses it holds may cost the change a little.
  constexpr double kSolveAboveNats = -1.0;
  const int num_classes = model_.num_classes();
  const double radius_m = TrackChangeRadiusM(options_.moves);
  // A candidate the evaluator cannot approximate is solved instead.
  auto take_best = [&](const std::vector<AssociationState>& changes) {
    EvaluationPtr best_approximate, best_solved;
    for (const AssociationState& change : changes) {
      EvaluationPtr approximate = evaluator->Approximate(change, *current);
      if (approximate && approximate->valid) {
        if (!best_approximate || approximate->log_target > best_approximate->log_target)
          best_approximate = approximate;
      } else if (!approximate) {
        EvaluationPtr solved = evaluator->Evaluate(change, current.get());
        if (solved && solved->valid &&
            (!best_solved || solved->log_target > best_solved->log_target))
          best_solved = solved;
      }
    }
    if (best_approximate && best_approximate->log_target - current->log_target >= kSolveAboveNats) {
      EvaluationPtr solved = evaluator->Evaluate(best_approximate->state, current.get());
      if (solved && solved->valid && (!best_solved || solved->log_target > best_solved->log_target))
        best_solved = solved;
    }
    if (!best_solved || !(best_solved->log_target > current->log_target)) return false;
    current = best_solved;
    ++summary->sweep_changes;
    summary->hill_climb_trace.push_back(current->log_target);
    return true;
  };
  for (int sweep = 0; sweep < options_.hill_climb_sweeps; ++sweep) {
    ++summary->sweeps;
    bool changed = false;
    for (int track = 0; track < model_.num_tracks(); ++track) {
      if (current->state.BlockOf(track) < 0) continue;
      changed |= take_best(TrackChanges(*current, track, model_, radius_m));
    }
    for (size_t j = 0; j < current->state.blocks.size(); ++j)
      changed |= take_best(ClassChanges(current->state, static_cast<int>(j), num_classes));
    EvaluationPtr refined = evaluator->Refine(current->state, current.get());
    if (refined && refined->valid) current = refined;
    if (!changed) break;
  }
  return current;
}

std::vector<int> Sampler::ContestedTracks(const EvaluationPtr& at,
                                          StateEvaluator* evaluator) const {
  if (options_.track_scan_max <= 0) return {};
  const double radius_m = TrackChangeRadiusM(options_.moves);
  std::vector<std::pair<double, int>> contested;  // (-best approximate gain, track)
  for (int track = 0; track < model_.num_tracks(); ++track) {
    if (at->state.BlockOf(track) < 0) continue;
    // The scan's own draw at beta = 1: log p(change) - log p(stay) is the
    // change's approximate gain.
    const TrackDraw draw = TrackDrawFrom(at, track, 1.0, radius_m, *evaluator, model_);
    if (draw.log_p.size() < 2) continue;
    const double best = *std::max_element(draw.log_p.begin() + 1, draw.log_p.end()) - draw.log_p[0];
    if (best >= -options_.track_scan_nats) contested.emplace_back(-best, track);
  }
  std::sort(contested.begin(), contested.end());
  if (contested.size() > static_cast<size_t>(options_.track_scan_max))
    contested.resize(options_.track_scan_max);
  std::vector<int> tracks;
  for (const auto& entry : contested) tracks.push_back(entry.second);
  std::sort(tracks.begin(), tracks.end());
  return tracks;
}

void Sampler::SampleChains(const std::vector<std::unique_ptr<StateEvaluator>>& evaluators,
                           const std::vector<Rng>& rngs, SamplerResult* result,
                           const ProgressCallback& progress) const {
  // Algorithm 8: every chain starts from the hill-climbed state.
  const auto clock = std::chrono::steady_clock::now();
  SamplerSummary& summary = result->summary;
  const int num_chains = options_.num_chains;
  std::vector<Chain> chains(num_chains);
  bool all_roll_back = true;
  for (int i = 0; i < num_chains; ++i) {
    chains[i].state = result->hill_climbed;
    chains[i].beta = 1.0 / (1.0 + options_.delta_temperature * i);
    chains[i].rng = rngs[i];
    chains[i].evaluator = evaluators[i].get();
    chains[i].evaluator->LineariseAt(result->hill_climbed);
    chains[i].evaluator->Remember(result->hill_climbed);
    if (i == 0) chains[i].scan_tracks = summary.scan_tracks;
    all_roll_back = all_roll_back && chains[i].evaluator->SupportsRollBack();
  }
  result->best = result->hill_climbed;
  ColdChainRecorder recorder(factory_, options_.burn_in, result);
  Rng swap_rng = ChainRng(options_.seed, -1);
  // Declared after the chains, so that its threads stop (also on an
  // exception) before the chains go.
  ChainStepper stepper(&chains, model_, options_, options_.parallel_chains && num_chains > 1,
                       all_roll_back ? options_.speculation_depth : 0);
  for (int block = 0; block < stepper.num_blocks(); ++block) {
    const std::vector<ChainCheckpoint> at = stepper.Next(block);
    const BlockIterations iterations = IterationsOf(block, options_);
    for (int t = iterations.first; t < iterations.last; ++t)
      recorder.Record(t, at[0].cold_states[t - iterations.first]);
    std::vector<EvaluationPtr> states(num_chains);
    for (int i = 0; i < num_chains; ++i) states[i] = at[i].state;
    const auto learnt = DecideSwaps(chains, &states, &swap_rng, &summary);
    std::vector<char> swapped(num_chains, 0);
    for (const auto& entry : learnt) swapped[entry.first] = 1;
    if (!learnt.empty()) {
      stepper.Hold(swapped);
      for (int i = 0; i < num_chains; ++i)
        if (swapped[i]) summary.speculative_solves_undone += SendBack(&chains[i], at[i], states[i]);
      // Each evaluator learns the state it receives.
      for (const auto& [i, state] : learnt) chains[i].evaluator->Remember(state);
    }
    recorder.Record(iterations.last, states[0]);
    stepper.Decided(block, swapped, at);
    if (progress) progress("MC3", iterations.last, options_.num_iterations);
  }
  stepper.Stop();
  summary.sampling = chains[0].stats;
  summary.track_scan = chains[0].scan;
  summary.sampling_time_s = SecondsSince(clock);
  summary.num_solves += recorder.num_solves();
}

}  // namespace oslam
