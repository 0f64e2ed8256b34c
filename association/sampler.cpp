#include "association/sampler.h"

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <thread>
#include <unordered_map>

#include "core/error.h"
#include "core/text.h"

namespace oslam {
namespace {

bool ValidProbabilities(const MoveProbabilities& p) {
  return p.merge >= 0 && p.split >= 0 && p.switch_class >= 0 &&
         std::abs(p.merge + p.split + p.switch_class - 1.0) < 1e-9;
}

// One random stream per chain, derived from the seed and the chain index.
Rng ChainRng(unsigned long seed, int chain) {
  std::seed_seq sequence{static_cast<unsigned>(seed), static_cast<unsigned>(seed >> 32),
                         static_cast<unsigned>(chain), 0x05a1u};
  return Rng(sequence);
}

// One MC3 chain: its state, temperature, random stream, statistics and evaluator.
struct Chain {
  EvaluationPtr state;
  double beta = 1.0;
  Rng rng;
  std::array<MoveStatistics, 3> stats{};
  StateEvaluator* evaluator = nullptr;
};

// A chain after a block of iterations: what going back to it needs.
struct ChainCheckpoint {
  EvaluationPtr state;
  Rng rng;
  std::array<MoveStatistics, 3> stats{};
  size_t mark = 0;                         // the evaluator's
  std::vector<EvaluationPtr> cold_states;  // chain 0: its state after each iteration
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
  if (!(hill_climb_screen_nats >= 0))
    return fail("the hill-climbing screen margin must be >= 0 nats (inf: solve every proposal)");
  if (!ValidProbabilities(hill_climb_moves) || !ValidProbabilities(sampling_moves))
    return fail("move probabilities must be >= 0 and sum to 1");
  if (num_chains < 1) return fail("at least one chain is needed");
  if (swap_every < 1) return fail("chains swap every >= 1 iterations");
  if (speculation_depth < 0) return fail("the speculation depth must be >= 0 swap intervals");
  if (!(delta_temperature >= 0) || std::isinf(delta_temperature))
    return fail("the temperature step dT must be >= 0");
  if (num_iterations < 1) return fail("at least one iteration is needed");
  if (burn_in < 0 || burn_in >= num_iterations)
    return fail("the burn-in must be >= 0 and below the number of iterations");
  return moves.Validate(why);
}

EvaluationPtr MetropolisStep(const EvaluationPtr& current, const StepRule& rule,
                             StateEvaluator& evaluator, const ClassConfusionModel& model,
                             const MoveOptions& options, const MoveProbabilities& probabilities,
                             Rng& rng, std::array<MoveStatistics, 3>* stats) {
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
    const EvaluationPtr approximate = evaluator.Approximate(proposal.state, *current);
    if (approximate && approximate->valid) {
      const double log_reverse =
          LogReverseProbability(proposal, *approximate, model, options, probabilities);
      const double log_alpha = beta * (approximate->log_target - current->log_target) +
                               log_reverse - proposal.log_q_forward;
      if (!std::isnan(log_alpha)) log_screen_forward = std::min(0.0, log_alpha);
    }
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
      double log_screen_reverse = 0.0;
      const EvaluationPtr approximate = evaluator.Approximate(current->state, *proposed);
      if (approximate && approximate->valid) {
        const double log_alpha1 =
            beta * (approximate->log_target - proposed->log_target) - log_reverse +
            LogForwardProbability(proposal, *approximate, model, options, probabilities);
        if (!std::isnan(log_alpha1)) log_screen_reverse = std::min(0.0, log_alpha1);
      }
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

SamplerResult Sampler::Run(const AssociationState& start_state, const ProgressCallback& progress) {
  std::string why;
  if (!options_.Validate(&why)) throw Error("sampler options: " + why);
  SamplerResult result;
  SamplerSummary& summary = result.summary;
  const int chains = options_.num_chains;
  std::vector<std::unique_ptr<StateEvaluator>> evaluators;
  std::vector<Rng> rngs;
  for (int i = 0; i < chains; ++i) {
    evaluators.push_back(factory_());
    rngs.push_back(ChainRng(options_.seed, i));
  }
  Rng swap_rng = ChainRng(options_.seed, -1);

  // Algorithm 9 steps 3-4: full optimisation, then greedy moves, refining
  // every K_NL steps (and replacing the cached value, spec §9.3).
  auto clock = std::chrono::steady_clock::now();
  AssociationState start = start_state;
  start.Canonicalize();
  EvaluationPtr current = evaluators[0]->Refine(start, nullptr);
  if (!current || !current->valid) throw Error("the start state could not be evaluated");
  summary.initial_log_target = current->log_target;
  auto refine = [&] {
    EvaluationPtr refined = evaluators[0]->Refine(current->state, current.get());
    if (refined && refined->valid) current = refined;
  };
  int last_accepted = 0, step = 0;
  auto go_on = [&] {
    if (step < options_.hill_climb_steps) return true;
    return options_.hill_climb_steps > 0 && options_.hill_climb_patience > 0 &&
           step < options_.hill_climb_max_steps &&
           step - last_accepted < options_.hill_climb_patience;
  };
  while (go_on()) {
    ++step;
    const EvaluationPtr before = current;
    StepRule climb;
    climb.greedy = true;
    climb.greedy_screen_nats = options_.hill_climb_screen_nats;
    current = MetropolisStep(current, climb, *evaluators[0], model_, options_.moves,
                             options_.hill_climb_moves, rngs[0], &summary.hill_climb);
    if (current != before) last_accepted = step;
    const bool last = !go_on();
    if (step % options_.refine_every == 0 || last) refine();
    summary.hill_climb_trace.push_back(current->log_target);
    if (progress)
      progress("hill climbing", std::min(step, options_.hill_climb_steps),
               options_.hill_climb_steps);
  }
  summary.hill_climb_steps = step;
  result.hill_climbed = current;
  summary.hill_climbed_log_target = current->log_target;
  summary.hill_climb_time_s = SecondsSince(clock);

  // Algorithm 8: every chain starts from the hill-climbed state.
  clock = std::chrono::steady_clock::now();
  std::vector<Chain> chain(chains);
  bool all_roll_back = true;
  for (int i = 0; i < chains; ++i) {
    chain[i].state = current;
    chain[i].beta = 1.0 / (1.0 + options_.delta_temperature * i);
    chain[i].rng = rngs[i];
    chain[i].evaluator = evaluators[i].get();
    chain[i].evaluator->Remember(current);
    all_roll_back = all_roll_back && chain[i].evaluator->SupportsRollBack();
  }
  result.best = current;
  // Recorded samples get their covariances from an evaluator of their own,
  // so that the chains never wait for it; a state is completed once.
  std::unique_ptr<StateEvaluator> completer;
  std::unordered_map<AssociationState, EvaluationPtr, AssociationStateHash> completed;
  auto record = [&](int t, const EvaluationPtr& cold) {
    summary.cold_trace.push_back(cold->log_target);
    if (cold->log_target > result.best->log_target) result.best = cold;
    if (t <= options_.burn_in) return;
    EvaluationPtr& done = completed[cold->state];
    if (!done) {
      if (!completer) completer = factory_();
      done = completer->Complete(cold);
    }
    result.samples.push_back(done);
  };
  const int swap_every = options_.swap_every;
  const int num_blocks = (options_.num_iterations + swap_every - 1) / swap_every;
  auto run_block = [&](int i, int block) {
    const int first = 1 + block * swap_every;
    const int last = std::min(options_.num_iterations, first + swap_every - 1);
    Chain& c = chain[i];
    ChainCheckpoint done;
    for (int t = first; t <= last; ++t) {
      StepRule sample;
      sample.beta = c.beta;
      sample.delayed_acceptance = options_.delayed_acceptance;
      c.state = MetropolisStep(c.state, sample, *c.evaluator, model_, options_.moves,
                               options_.sampling_moves, c.rng, &c.stats);
      if (i == 0) done.cold_states.push_back(c.state);
    }
    done.state = c.state;
    done.rng = c.rng;
    done.stats = c.stats;
    done.mark = c.evaluator->Mark();
    return done;
  };
  // With threads every chain runs in its own, up to `depth` blocks ahead of
  // the swap decisions (speculation); a chain that an accepted swap reaches
  // goes back to its checkpoint at that swap, so the result is the one of
  // stepping the chains one after another.
  const bool threaded = options_.parallel_chains && chains > 1;
  const int depth = all_roll_back ? options_.speculation_depth : 0;
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::deque<ChainCheckpoint>> published(chains);
  std::vector<int> next_block(chains, 0);
  std::vector<char> hold(chains, 0), held(chains, 0), release_pending(chains, 0);
  std::vector<size_t> release_mark(chains, 0);
  int decided = 0;  // blocks whose swaps are decided
  bool stop = false;
  std::exception_ptr failure;  // thrown in a chain's thread, rethrown here
  auto chain_thread = [&](int i) {
    for (;;) {
      int block;
      size_t release = 0;
      bool do_release = false;
      {
        std::unique_lock<std::mutex> lock(mutex);
        for (;;) {
          if (stop) return;
          if (hold[i]) {
            held[i] = 1;
            changed.notify_all();
          } else if (next_block[i] < num_blocks && next_block[i] <= decided + depth) {
            break;
          }
          changed.wait(lock);
        }
        block = next_block[i];
        do_release = release_pending[i];
        release_pending[i] = 0;
        release = release_mark[i];
      }
      ChainCheckpoint done;
      try {
        if (do_release) chain[i].evaluator->Release(release);
        done = run_block(i, block);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!failure) failure = std::current_exception();
        changed.notify_all();
        return;
      }
      std::lock_guard<std::mutex> lock(mutex);
      published[i].push_back(std::move(done));
      ++next_block[i];
      changed.notify_all();
    }
  };
  std::vector<std::thread> threads;
  if (threaded)
    for (int i = 0; i < chains; ++i) threads.emplace_back(chain_thread, i);
  auto stop_threads = [&] {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
    }
    changed.notify_all();
    for (auto& thread : threads) thread.join();
  };
  try {
    for (int block = 0; block < num_blocks; ++block) {
      const int first = 1 + block * swap_every;
      const int last = std::min(options_.num_iterations, first + swap_every - 1);
      std::vector<ChainCheckpoint> at(chains);
      if (threaded) {
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock, [&] {
          if (failure) return true;
          for (const auto& queue : published)
            if (queue.empty()) return false;
          return true;
        });
        if (failure) std::rethrow_exception(failure);
        for (int i = 0; i < chains; ++i) {
          at[i] = std::move(published[i].front());
          published[i].pop_front();
        }
      } else {
        for (int i = 0; i < chains; ++i) at[i] = run_block(i, block);
      }
      for (int t = first; t < last; ++t) record(t, at[0].cold_states[t - first]);
      // Swaps of adjacent chains, hottest pair first (5.3); whole states
      // move, and each evaluator learns the state it receives.
      std::vector<EvaluationPtr> states(chains);
      for (int i = 0; i < chains; ++i) states[i] = at[i].state;
      std::vector<std::pair<int, EvaluationPtr>> learnt;
      for (int i = chains - 1; i >= 1; --i) {
        ++summary.swaps_proposed;
        const double log_alpha = (chain[i - 1].beta - chain[i].beta) *
                                 (states[i]->log_target - states[i - 1]->log_target);
        const double u = std::uniform_real_distribution<double>(0.0, 1.0)(swap_rng);
        if (std::log(u) < std::min(0.0, log_alpha)) {
          std::swap(states[i], states[i - 1]);
          learnt.emplace_back(i, states[i]);
          learnt.emplace_back(i - 1, states[i - 1]);
          ++summary.swaps_accepted;
        }
      }
      std::vector<char> swapped(chains, 0);
      for (const auto& entry : learnt) swapped[entry.first] = 1;
      if (!learnt.empty()) {
        if (threaded) {  // wait until the swapped chains are between blocks
          std::unique_lock<std::mutex> lock(mutex);
          for (int i = 0; i < chains; ++i) hold[i] = swapped[i];
          changed.notify_all();
          changed.wait(lock, [&] {
            if (failure) return true;
            for (int i = 0; i < chains; ++i)
              if (swapped[i] && !held[i]) return false;
            return true;
          });
          if (failure) std::rethrow_exception(failure);
        }
        for (int i = 0; i < chains; ++i) {
          if (!swapped[i]) continue;
          const size_t solves = chain[i].evaluator->num_solves();
          chain[i].evaluator->RollBack(at[i].mark);
          summary.speculative_solves_undone += solves - chain[i].evaluator->num_solves();
          chain[i].evaluator->Release(at[i].mark);
          chain[i].state = states[i];
          chain[i].rng = at[i].rng;
          chain[i].stats = at[i].stats;
        }
        for (const auto& [i, state] : learnt) chain[i].evaluator->Remember(state);
      }
      record(last, states[0]);
      {
        std::lock_guard<std::mutex> lock(mutex);
        for (int i = 0; i < chains; ++i) {
          if (swapped[i]) {
            published[i].clear();
            next_block[i] = block + 1;
            hold[i] = held[i] = 0;
          } else if (threaded) {
            release_pending[i] = 1;
            release_mark[i] = at[i].mark;
          } else {
            chain[i].evaluator->Release(at[i].mark);
          }
        }
        decided = block + 1;
      }
      changed.notify_all();
      if (progress) progress("MC3", last, options_.num_iterations);
    }
  } catch (...) {
    stop_threads();
    throw;
  }
  stop_threads();
  summary.sampling = chain[0].stats;
  summary.sampling_time_s = SecondsSince(clock);
  if (completer) summary.num_solves += completer->num_solves();
  for (const auto& evaluator : evaluators) {
    summary.num_solves += evaluator->num_solves();
    summary.num_cache_hits += evaluator->num_cache_hits();
  }
  summary.effective_sample_size = EffectiveSampleSize(
      std::vector<double>(summary.cold_trace.begin() + options_.burn_in, summary.cold_trace.end()));
  summary.message = "ok";
  return result;
}

}  // namespace oslam
