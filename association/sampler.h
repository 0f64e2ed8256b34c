// O-SLAM inference over (C, J) (docs/method.md §9.1, §9.4, §9.7 Algorithm 9): a
// hill-climbing phase from the all-tracks-separate state, then
// Metropolis-coupled MCMC (MC³; plain Metropolis-Hastings is the one-chain
// case). Chains step in parallel threads; each chain owns its random stream
// and its evaluator, so a run is reproducible from the seed with or without
// threads.
#pragma once

#include <array>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "association/moves.h"

namespace oslam {

struct SamplerOptions {
  int hill_climb_steps = 100;  // 100 (Sec. 6.2), 400 (long run); the minimum
  // Beyond hill_climb_steps, climbing goes on while a move was accepted in
  // the last `hill_climb_patience` steps (0: stop at hill_climb_steps, the
  // thesis' fixed count), up to hill_climb_max_steps. A fixed count that
  // suits lab's ~40 tracks leaves long_loop's ~180 tracks half merged.
  int hill_climb_patience = 50;
  int hill_climb_max_steps = 2000;
  // Hill climbing skips the solve of a proposal whose approximate gain (the
  // delayed-acceptance approximation) is below -hill_climb_screen_nats: it
  // would not raise the target. long_loop: -10 skips 60 % of the solves and
  // none that the solve would have accepted. Infinity: solve every proposal.
  double hill_climb_screen_nats = 10.0;
  int refine_every = 50;  // K_NL: full optimisation of the current state
  // Beyond the thesis (docs/method.md §9.7): after the random climb, at most
  // this many sweeps over every track (moved into each object within
  // 3 sigma_R or alone, the objects it joins and leaves at their class or
  // their detections' likeliest) and every object (each other class), each
  // taking its best single change when it raises the target. The random
  // climb proposes such changes too seldom to finish them: on long_loop MC³
  // went on finding states 5-20 nats above it for its whole run. 0 = thesis.
  int hill_climb_sweeps = 5;
  MoveProbabilities hill_climb_moves{0.9, 0.1, 0.0};
  MoveProbabilities sampling_moves{0.4, 0.4, 0.2};  // 0.5/0.5/0 with known classes
  MoveOptions moves;
  int num_chains = 3;  // N_c; 1 = plain Metropolis-Hastings
  // Metropolis-Hastings steps of the cold chain per iteration (1: Algorithm
  // 8); the others take one. Beyond the thesis (docs/method.md §9.4): the
  // cold chain's proposals are mostly screened out cheaply, so thinning it
  // buys effective samples for less than more iterations of every chain.
  // 2 with the track scan (long_loop: ESS at least as high as with 3, for
  // less CPU; docs/method.md §9.4).
  int cold_chain_steps = 2;
  // beta_i = 1 / (1 + dT (i - 1)). 3.33 in the thesis; 0.5 beyond it
  // (docs/method.md §9.4): at 3.33 the hot chains' states are tens of nats
  // below the cold chain's and 2 % of swaps are accepted; at 0.5 about 25 %.
  double delta_temperature = 0.5;
  // Adjacent chains may swap after every `swap_every` iterations (1: after
  // each, Algorithm 8); any schedule keeps the tempered targets invariant.
  int swap_every = 1;
  // Iterations t = 1..num_iterations; the cold chain's state is recorded when
  // t > burn_in (Algorithm 8), so num_iterations counts the burn-in (#21).
  // The thesis runs 667; 1,500 give long_loop's log target an effective
  // sample size of about 100 or more (docs/method.md §9.4).
  int num_iterations = 1500;
  int burn_in = 70;
  unsigned long seed = 1;
  bool parallel_chains = true;
  // With threads, a chain may step up to this many swap intervals ahead of
  // the swap decisions, so that it waits for no other chain; an accepted swap
  // sends the chains it reaches back to that iteration (their evaluators roll
  // back), and the result is the one of stepping the chains one after another.
  // 0 (or an evaluator that cannot roll back): the chains step in lock-step.
  // Default 0: with ΔT 0.5 a quarter of the swaps are accepted, and the work
  // done ahead of them was lost (long_loop: O-SLAM 2.3-2.5 s wall at depth 8,
  // 1.6-1.8 s in lock-step; docs/method.md §9.4).
  int speculation_depth = 0;
  // MC³ proposals pass a cheap screen before they are solved (delayed
  // acceptance, Christen & Fox 2005): the first stage accepts with
  // min(1, exp(beta a(x, y))), a = the evaluator's approximate log ratio, the
  // second corrects with the exact target, so the chain keeps the same
  // stationary distribution; proposals the screen rejects cost no solve.
  // Hill climbing never screens. Off: plain Metropolis-Hastings (thesis).
  bool delayed_acceptance = true;
  // Beyond the thesis (docs/method.md §9.4): after its steps in each
  // iteration the cold chain updates each contested track in turn, drawing
  // where it goes (stay, into an object within 3 sigma_R, or alone) in
  // proportion to the approximate target and correcting with the exact one.
  // Contested: a single change of the track is within track_scan_nats of the
  // hill-climbed state by the approximation; at most track_scan_max tracks,
  // the closest first (0 = off). The tracks are fixed before MC3 starts, so
  // the chain's target is unchanged.
  int track_scan_max = 8;
  double track_scan_nats = 10.0;

  bool Validate(std::string* why) const;
};

struct MoveStatistics {
  long proposed = 0, accepted = 0, self_transitions = 0;
  long cache_hits = 0;    // proposed states found in the evaluator's cache (no solve)
  long screened_out = 0;  // rejected by delayed acceptance's first stage (no solve)
  double time_s = 0;      // spent evaluating proposals of this type (screen included)
  // Proposals that needed a solve.
  long solves() const { return proposed - self_transitions - cache_hits - screened_out; }
  // Proposals that were screened, looked up or solved (all but self-transitions).
  long evaluated() const { return proposed - self_transitions; }
};

struct SamplerSummary {
  std::array<MoveStatistics, kNumMoveTypes> hill_climb{}, sampling{};  // by MoveType, cold chain
  long swaps_proposed = 0, swaps_accepted = 0;
  // Solves done ahead of a swap that was then accepted, and undone (depend on
  // the threads' timing; not in num_solves).
  size_t speculative_solves_undone = 0;
  int hill_climb_steps = 0;              // taken (patience may add to the minimum)
  int sweeps = 0, sweep_changes = 0;     // the sweeps after the climb and what they changed
  std::vector<int> scan_tracks;          // the contested tracks MC3's cold chain updates
  MoveStatistics track_scan{};           // their updates (proposed = updates, accepted = moves)
  std::vector<double> hill_climb_trace;  // log target of the current state per step
  std::vector<double> cold_trace;        // cold chain's log target per iteration
  double initial_log_target = 0, hill_climbed_log_target = 0;
  size_t num_solves = 0, num_cache_hits = 0;
  double hill_climb_time_s = 0, sampling_time_s = 0;
  double effective_sample_size = 0;  // of the cold chain's log target (after burn-in)
  std::string message;
};

struct SamplerResult {
  std::vector<EvaluationPtr> samples;  // cold chain, one per recorded iteration
  EvaluationPtr hill_climbed;          // the state MC³ started from
  EvaluationPtr best;                  // highest log target seen by the cold chain
  SamplerSummary summary;
};

using EvaluatorFactory = std::function<std::unique_ptr<StateEvaluator>()>;
using ProgressCallback = std::function<void(const char* stage, size_t done, size_t total)>;

class Sampler {
 public:
  Sampler(const ClassConfusionModel& model, EvaluatorFactory factory,
          const SamplerOptions& options);
  // Throws oslam::Error on invalid options or an unevaluable start state.
  SamplerResult Run(const AssociationState& start, const ProgressCallback& progress = {});

 private:
  // Algorithm 9 steps 3-4 from `start`; returns the hill-climbed state.
  EvaluationPtr HillClimb(const AssociationState& start, StateEvaluator* evaluator, Rng* rng,
                          SamplerSummary* summary, const ProgressCallback& progress) const;
  // The sweeps of SamplerOptions::hill_climb_sweeps from `current`.
  EvaluationPtr Sweep(EvaluationPtr current, StateEvaluator* evaluator,
                      SamplerSummary* summary) const;
  // The tracks of SamplerOptions::track_scan_max at `at`, by track id.
  std::vector<int> ContestedTracks(const EvaluationPtr& at, StateEvaluator* evaluator) const;
  // Algorithm 8 from result->hill_climbed: chain i steps with evaluators[i]
  // and a copy of rngs[i]; fills the samples, the best state and the summary's
  // sampling part.
  void SampleChains(const std::vector<std::unique_ptr<StateEvaluator>>& evaluators,
                    const std::vector<Rng>& rngs, SamplerResult* result,
                    const ProgressCallback& progress) const;

  const ClassConfusionModel& model_;
  EvaluatorFactory factory_;
  SamplerOptions options_;
};

// How a Metropolis-Hastings step decides; the sampler's phases differ only here.
struct StepRule {
  double beta = 1.0;    // inverse temperature of the target
  bool greedy = false;  // accept only increases of the target (hill climbing)
  // Not greedy: screen the proposal first (SamplerOptions::delayed_acceptance).
  bool delayed_acceptance = false;
  // Greedy: reject without a solve when the approximate gain is below
  // -greedy_screen_nats (SamplerOptions::hill_climb_screen_nats).
  double greedy_screen_nats = std::numeric_limits<double>::infinity();
};

// One Metropolis-Hastings step: proposes from `current` and returns the next
// state (the current one when rejected). Counts into `stats` (indexed by
// MoveType).
EvaluationPtr MetropolisStep(const EvaluationPtr& current, const StepRule& rule,
                             StateEvaluator& evaluator, const ClassConfusionModel& model,
                             const MoveOptions& options, const MoveProbabilities& probabilities,
                             Rng& rng, std::array<MoveStatistics, kNumMoveTypes>* stats);

// Integrated-autocorrelation effective sample size (initial positive sequence).
double EffectiveSampleSize(const std::vector<double>& series);

}  // namespace oslam
