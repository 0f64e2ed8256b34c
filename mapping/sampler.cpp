#include "mapping/sampler.h"

#include <chrono>
#include <cmath>
#include <thread>

#include "core/error.h"

namespace oslam {
namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

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
      stat.time_s += Seconds(start);
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
      stat.time_s += Seconds(start);
      return current;
    }
  }
  const size_t hits_before = evaluator.num_cache_hits();
  EvaluationPtr proposed = evaluator.Evaluate(proposal.state, current.get());
  stat.cache_hits += static_cast<long>(evaluator.num_cache_hits() - hits_before);
  if (!proposed || !proposed->valid) {
    stat.time_s += Seconds(start);
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
  stat.time_s += Seconds(start);
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
  summary.hill_climb_time_s = Seconds(clock);

  // Algorithm 8: every chain starts from the hill-climbed state.
  clock = std::chrono::steady_clock::now();
  std::vector<EvaluationPtr> states(chains, current);
  std::vector<double> beta(chains);
  for (int i = 0; i < chains; ++i) {
    beta[i] = 1.0 / (1.0 + options_.delta_temperature * i);
    evaluators[i]->Remember(current);
  }
  std::vector<std::array<MoveStatistics, 3>> stats(chains);
  result.best = current;
  // The cold chain's state after iteration t: traced, and recorded after the burn-in.
  auto record = [&](int t, const EvaluationPtr& cold) {
    summary.cold_trace.push_back(cold->log_target);
    if (cold->log_target > result.best->log_target) result.best = cold;
    if (t <= options_.burn_in) return cold;
    EvaluationPtr completed = evaluators[0]->Complete(cold);
    result.samples.push_back(completed);
    return completed;
  };
  // Chains step independently for swap_every iterations (in parallel
  // threads), then adjacent chains may swap.
  for (int first = 1; first <= options_.num_iterations; first += options_.swap_every) {
    const int last = std::min(options_.num_iterations, first + options_.swap_every - 1);
    std::vector<EvaluationPtr> cold_states(last - first + 1);
    auto run_chain = [&](int i) {
      for (int t = first; t <= last; ++t) {
        StepRule sample;
        sample.beta = beta[i];
        sample.delayed_acceptance = options_.delayed_acceptance;
        states[i] = MetropolisStep(states[i], sample, *evaluators[i], model_, options_.moves,
                                   options_.sampling_moves, rngs[i], &stats[i]);
        if (i == 0) cold_states[t - first] = states[0];
      }
    };
    if (options_.parallel_chains && chains > 1) {
      std::vector<std::thread> threads;
      for (int i = 1; i < chains; ++i) threads.emplace_back(run_chain, i);
      run_chain(0);
      for (auto& thread : threads) thread.join();
    } else {
      for (int i = 0; i < chains; ++i) run_chain(i);
    }
    for (int t = first; t < last; ++t) record(t, cold_states[t - first]);
    // Swaps of adjacent chains, hottest pair first (5.3); whole states move,
    // and each evaluator learns the state it receives.
    for (int i = chains - 1; i >= 1; --i) {
      ++summary.swaps_proposed;
      const double log_alpha =
          (beta[i - 1] - beta[i]) * (states[i]->log_target - states[i - 1]->log_target);
      const double u = std::uniform_real_distribution<double>(0.0, 1.0)(swap_rng);
      if (std::log(u) < std::min(0.0, log_alpha)) {
        std::swap(states[i], states[i - 1]);
        evaluators[i]->Remember(states[i]);
        evaluators[i - 1]->Remember(states[i - 1]);
        ++summary.swaps_accepted;
      }
    }
    states[0] = record(last, states[0]);
    if (progress) progress("MC3", last, options_.num_iterations);
  }
  summary.sampling = stats[0];
  summary.sampling_time_s = Seconds(clock);
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
