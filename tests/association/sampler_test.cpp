// The samplers (sampler.h): detailed balance of Metropolis-Hastings and of
// MC³'s cold chain on the enumerable 4-track, 2-class problem (spec §9.2-9.4):
// the visit frequencies must match the exact posterior of the same target;
// hill climbing; reproducibility from the seed, with threads and speculation.
#include "association/sampler.h"

#include <cmath>
#include <limits>
#include <random>
#include <unordered_map>

#include <gtest/gtest.h>

#include "association/association_fixture.h"
#include "core/error.h"

namespace oslam {
namespace {

using testing::EnumerateStates;
using testing::kTrackClass;
using testing::TestEvaluator;
using testing::TestLogTarget;
using testing::TestModel;

// Total variation distance between the sample frequencies and the exact posterior.
double TotalVariation(const SamplerResult& result, const ClassConfusionModel& model) {
  const std::vector<AssociationState> states = EnumerateStates(4, 2);
  std::vector<double> log_p;
  for (const auto& s : states) log_p.push_back(TestLogTarget(s, model));
  const double max = *std::max_element(log_p.begin(), log_p.end());
  double z = 0;
  for (double v : log_p) z += std::exp(v - max);
  std::unordered_map<AssociationState, double, AssociationStateHash> frequency;
  for (const auto& sample : result.samples) frequency[sample->state] += 1.0 / result.samples.size();
  double tv = 0, covered = 0;
  for (size_t i = 0; i < states.size(); ++i) {
    const double exact = std::exp(log_p[i] - max) / z;
    const double seen = frequency.count(states[i]) ? frequency[states[i]] : 0.0;
    covered += seen;
    tv += 0.5 * std::abs(seen - exact);
  }
  EXPECT_NEAR(covered, 1.0, 1e-9) << "a sample left the enumerated state space";
  return tv;
}

SamplerOptions TestOptions(int chains, int iterations) {
  SamplerOptions options;
  options.hill_climb_steps = 0;
  options.num_chains = chains;
  options.num_iterations = iterations;
  options.burn_in = 1000;
  options.seed = 7;
  return options;
}

// approximation_error > 0: the evaluators offer approximations (delayed
// acceptance); roll_back false: they cannot roll back (chains in lock-step).
SamplerResult RunTest(const SamplerOptions& options, const ClassConfusionModel& model,
                      double approximation_error = 0, bool roll_back = true) {
  Sampler sampler(
      model,
      [&model, approximation_error, roll_back] {
        auto evaluator = std::make_unique<TestEvaluator>(model);
        if (approximation_error > 0) evaluator->EnableApproximation(approximation_error);
        if (!roll_back) evaluator->DisableRollBack();
        return evaluator;
      },
      options);
  return sampler.Run(SeparateTracksState(kTrackClass));
}

// Sample counts and tolerance: 200,000 MH iterations on 94 states; the
// stated tolerance for the total variation distance is 0.03.
TEST(DetailedBalanceTest, MetropolisHastingsMatchesEnumeratedPosterior) {
  const ClassConfusionModel model = TestModel();
  const SamplerResult result = RunTest(TestOptions(1, 200000), model);
  const double tv = TotalVariation(result, model);
  RecordProperty("total_variation", std::to_string(tv));
  std::printf("MH: %zu samples, total variation %.4f\n", result.samples.size(), tv);
  EXPECT_LT(tv, 0.03);
  for (int m = 0; m < 3; ++m) EXPECT_GT(result.summary.sampling[m].accepted, 0) << m;
}

// Delayed acceptance with a deliberately poor screen (target off by up to
// +-2, locations moved, no approximation for 1 pair in 7) must leave the
// posterior unchanged: same tolerance as plain MH.
TEST(DetailedBalanceTest, DelayedAcceptanceKeepsTheEnumeratedPosterior) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(1, 200000);
  options.delayed_acceptance = true;
  const SamplerResult result = RunTest(options, model, 2.0);
  const double tv = TotalVariation(result, model);
  long screened = 0;
  for (const MoveStatistics& m : result.summary.sampling) screened += m.screened_out;
  std::printf("MH with delayed acceptance: total variation %.4f, %ld screened out\n", tv, screened);
  EXPECT_LT(tv, 0.03);
  EXPECT_GT(screened, 10000);
  for (int m = 0; m < 3; ++m) EXPECT_GT(result.summary.sampling[m].accepted, 0) << m;
}

TEST(DetailedBalanceTest, MetropolisCoupledWithDelayedAcceptance) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(3, 100000);
  options.parallel_chains = false;
  options.delayed_acceptance = true;
  const double tv = TotalVariation(RunTest(options, model, 1.0), model);
  std::printf("MC3 with delayed acceptance: total variation %.4f\n", tv);
  EXPECT_LT(tv, 0.03);
}

TEST(DetailedBalanceTest, ThesisSplitSamplerWithItsTrueProbability) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(1, 200000);
  options.moves.split_sampler = SplitSampler::kThesis;
  options.moves.merge_count_includes_self = true;
  options.moves.merge_count_smoothing = 0;
  const double tv = TotalVariation(RunTest(options, model), model);
  std::printf("MH (thesis split sampler, self-count): total variation %.4f\n", tv);
  EXPECT_LT(tv, 0.03);
}

TEST(DetailedBalanceTest, MetropolisCoupledColdChainMatchesEnumeratedPosterior) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(3, 100000);
  options.parallel_chains = false;  // same result (tested below); threads per step cost more here
  const SamplerResult result = RunTest(options, model);
  const double tv = TotalVariation(result, model);
  std::printf("MC3: %zu samples, total variation %.4f, swaps %ld/%ld\n", result.samples.size(), tv,
              result.summary.swaps_accepted, result.summary.swaps_proposed);
  EXPECT_LT(tv, 0.03);
  EXPECT_GT(result.summary.swaps_accepted, 0);
}

TEST(SamplerTest, ReproducibleFromTheSeedWithThreads) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(3, 3000);
  const SamplerResult a = RunTest(options, model);
  options.parallel_chains = false;
  const SamplerResult b = RunTest(options, model);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (size_t i = 0; i < a.samples.size(); ++i) ASSERT_EQ(a.samples[i]->state, b.samples[i]->state);
  options.seed = 8;
  const SamplerResult c = RunTest(options, model);
  size_t differ = 0;
  for (size_t i = 0; i < a.samples.size(); ++i)
    differ += !(a.samples[i]->state == c.samples[i]->state);
  EXPECT_GT(differ, 0u);
}

// Chains on threads that run ahead of the swap decisions (and go back when a
// swap reaches them) give exactly the sequential result: the same samples,
// move statistics and solve counts. A small temperature step makes swaps
// frequent, so chains are sent back often.
TEST(SamplerTest, SpeculativeChainsGiveTheSequentialResult) {
  const ClassConfusionModel model = TestModel();
  for (int swap_every : {1, 3}) {
    SamplerOptions options = TestOptions(3, 1500);
    options.burn_in = 100;
    options.delta_temperature = 0.3;
    options.swap_every = swap_every;
    options.parallel_chains = false;
    const SamplerResult reference = RunTest(options, model, 1.0);
    EXPECT_GT(reference.summary.swaps_accepted, reference.summary.swaps_proposed / 4);
    options.parallel_chains = true;
    for (const auto& [depth, roll_back] :
         {std::pair{0, true}, {1, true}, {32, true}, {32, false}}) {
      options.speculation_depth = depth;
      const SamplerResult result = RunTest(options, model, 1.0, roll_back);
      SCOPED_TRACE("swap every " + std::to_string(swap_every) + ", depth " + std::to_string(depth) +
                   (roll_back ? "" : ", no roll-back"));
      ASSERT_EQ(result.samples.size(), reference.samples.size());
      for (size_t i = 0; i < result.samples.size(); ++i)
        ASSERT_EQ(result.samples[i]->state, reference.samples[i]->state) << i;
      EXPECT_EQ(result.summary.cold_trace, reference.summary.cold_trace);
      EXPECT_EQ(result.summary.swaps_accepted, reference.summary.swaps_accepted);
      EXPECT_EQ(result.summary.num_solves, reference.summary.num_solves);
      EXPECT_EQ(result.summary.num_cache_hits, reference.summary.num_cache_hits);
      for (int m = 0; m < 3; ++m) {
        EXPECT_EQ(result.summary.sampling[m].accepted, reference.summary.sampling[m].accepted);
        EXPECT_EQ(result.summary.sampling[m].screened_out,
                  reference.summary.sampling[m].screened_out);
        EXPECT_EQ(result.summary.sampling[m].cache_hits, reference.summary.sampling[m].cache_hits);
      }
    }
  }
}

TEST(SamplerTest, HillClimbingNeverDecreasesTheTarget) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(1, 2);
  options.burn_in = 0;
  options.hill_climb_steps = 200;
  const SamplerResult result = RunTest(options, model);
  double previous = result.summary.initial_log_target;
  for (double v : result.summary.hill_climb_trace) {
    EXPECT_GE(v, previous);
    previous = v;
  }
  EXPECT_GT(result.summary.hill_climbed_log_target, result.summary.initial_log_target);
}

// With an exact approximation and a 0-nat margin, the hill-climbing screen
// skips exactly the proposals the solve would reject: same climb, fewer solves.
TEST(SamplerTest, HillClimbingScreenSkipsOnlyWhatWouldBeRejected) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(1, 2);
  options.burn_in = 0;
  options.hill_climb_steps = 200;
  options.hill_climb_patience = 0;
  std::vector<SamplerResult> results;
  for (double margin : {std::numeric_limits<double>::infinity(), 0.0}) {
    options.hill_climb_screen_nats = margin;
    Sampler sampler(
        model,
        [&model] {
          auto evaluator = std::make_unique<TestEvaluator>(model);
          evaluator->EnableApproximation(0.0);
          return evaluator;
        },
        options);
    results.push_back(sampler.Run(SeparateTracksState(kTrackClass)));
  }
  EXPECT_EQ(results[0].summary.hill_climb_trace, results[1].summary.hill_climb_trace);
  long screened = 0;
  for (const MoveStatistics& m : results[1].summary.hill_climb) screened += m.screened_out;
  EXPECT_GT(screened, 20);
  for (const MoveStatistics& m : results[0].summary.hill_climb) EXPECT_EQ(m.screened_out, 0);
}

// Climbing stops exactly `patience` steps after the last accepted move once
// the minimum is done, never before the minimum, never beyond the maximum.
TEST(SamplerTest, HillClimbingGoesOnWhileItImprovesWithinTheLimits) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(1, 2);
  options.burn_in = 0;
  options.hill_climb_steps = 3;
  options.hill_climb_patience = 25;
  const SamplerResult result = RunTest(options, model);
  const auto& trace = result.summary.hill_climb_trace;
  ASSERT_EQ(static_cast<int>(trace.size()), result.summary.hill_climb_steps);
  ASSERT_GE(result.summary.hill_climb_steps, options.hill_climb_patience);
  int last_change = 0;
  double previous = result.summary.initial_log_target;
  for (size_t i = 0; i < trace.size(); ++i) {
    if (trace[i] != previous) last_change = static_cast<int>(i) + 1;
    previous = trace[i];
  }
  // The last step's refinement may itself change the value; otherwise the
  // stop comes `patience` steps after the last improvement.
  EXPECT_LE(result.summary.hill_climb_steps - last_change, options.hill_climb_patience);

  options.hill_climb_patience = 0;  // the thesis' fixed count
  EXPECT_EQ(RunTest(options, model).summary.hill_climb_steps, 3);
  options.hill_climb_patience = 1000;
  options.hill_climb_max_steps = 40;
  EXPECT_EQ(RunTest(options, model).summary.hill_climb_steps, 40);
  options.hill_climb_max_steps = 2;  // below the minimum
  EXPECT_THROW(RunTest(options, model), Error);
}

TEST(SamplerTest, EffectiveSampleSizeOfIndependentAndCorrelatedSeries) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  std::vector<double> independent(4000), correlated(4000);
  double ar = 0;
  for (size_t i = 0; i < independent.size(); ++i) {
    independent[i] = normal(rng);
    ar = 0.9 * ar + normal(rng);
    correlated[i] = ar;
  }
  EXPECT_GT(EffectiveSampleSize(independent), 3000);
  // AR(1) with rho = 0.9: n (1 - rho) / (1 + rho) = 4000 / 19 = 211.
  EXPECT_NEAR(EffectiveSampleSize(correlated), 211, 80);
}

}  // namespace
}  // namespace oslam
