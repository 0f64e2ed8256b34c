// The samplers (sampler.h): detailed balance of Metropolis-Hastings and of
// MC³'s cold chain on the enumerable 4-track, 2-class problem (docs/method.md §9.2-9.4):
// the visit frequencies must match the exact posterior of the same target;
// hill climbing; reproducibility from the seed, with threads and speculation;
// what a run records and how it fails; the Metropolis step; the effective
// sample size.
#include "association/sampler.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
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
  // Every move, the reassign move beyond the thesis included; one step per
  // iteration (Algorithm 8), so the sample counts say what the tests state.
  options.sampling_moves = {0.3, 0.3, 0.2, 0.2};
  options.cold_chain_steps = 1;
  options.hill_climb_sweeps = 0;
  options.track_scan_max = 0;  // the scan's own tests turn it on
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

// A run whose evaluators approximate every state exactly where they
// approximate it (the test evaluator withholds some approximations).
SamplerResult RunExactlyApproximated(const SamplerOptions& options,
                                     const ClassConfusionModel& model) {
  Sampler sampler(
      model,
      [&model] {
        auto evaluator = std::make_unique<TestEvaluator>(model);
        evaluator->EnableApproximation(0.0);
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
  for (int m = 0; m < kNumMoveTypes; ++m) EXPECT_GT(result.summary.sampling[m].accepted, 0) << m;
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
  for (int m = 0; m < kNumMoveTypes; ++m) EXPECT_GT(result.summary.sampling[m].accepted, 0) << m;
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

// Splitting off one track half the time, with the mixture's partition
// probability forward and in reverse (docs/method.md §9.2).
TEST(DetailedBalanceTest, OneTrackOrUniformSplitSampler) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(1, 200000);
  options.moves.split_sampler = SplitSampler::kOneTrackOrUniform;
  const SamplerResult result = RunTest(options, model);
  const double tv = TotalVariation(result, model);
  std::printf("MH (one-track-or-uniform split sampler): total variation %.4f\n", tv);
  EXPECT_LT(tv, 0.03);
  EXPECT_GT(result.summary.sampling[static_cast<int>(MoveType::kSplit)].accepted, 0);
}

// Several steps of the cold chain per iteration (thinning, docs/method.md
// §9.4) leave its posterior unchanged: same tolerance, with delayed
// acceptance and the reassign move in the mix.
TEST(DetailedBalanceTest, ColdChainStepsKeepTheEnumeratedPosterior) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(3, 40000);
  options.parallel_chains = false;
  options.delayed_acceptance = true;
  options.cold_chain_steps = 3;
  const SamplerResult result = RunTest(options, model, 1.0);
  const double tv = TotalVariation(result, model);
  long proposed = 0;
  for (const MoveStatistics& m : result.summary.sampling) proposed += m.proposed;
  std::printf("MC3, 3 cold-chain steps per iteration: total variation %.4f\n", tv);
  EXPECT_LT(tv, 0.03);
  EXPECT_EQ(proposed, 3L * options.num_iterations);  // the cold chain's statistics
  EXPECT_EQ(result.summary.cold_trace.size(), static_cast<size_t>(options.num_iterations));
}

// The cold chain's track scan (docs/method.md §9.4): each contested track's
// place drawn from a deliberately poor approximation (off by up to +-1 nats,
// none for 1 pair in 7) and corrected by the exact target keeps the
// posterior; every track contested.
TEST(DetailedBalanceTest, TrackScanKeepsTheEnumeratedPosterior) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(3, 40000);
  options.parallel_chains = false;
  options.delayed_acceptance = true;
  options.track_scan_max = 4;
  options.track_scan_nats = std::numeric_limits<double>::infinity();
  const SamplerResult result = RunTest(options, model, 1.0);
  const double tv = TotalVariation(result, model);
  std::printf("MC3 with the track scan: total variation %.4f, %ld of %ld updates moved a track\n",
              tv, result.summary.track_scan.accepted, result.summary.track_scan.proposed);
  EXPECT_LT(tv, 0.03);
  EXPECT_EQ(result.summary.scan_tracks.size(), 4u);
  EXPECT_EQ(result.summary.track_scan.proposed, 4L * options.num_iterations);
  EXPECT_GT(result.summary.track_scan.accepted, 1000);
}

// On by default (8 tracks), off at 0, and a bad setting is named.
TEST(SamplerTest, TrackScanIsOnByDefaultOffAtZeroAndValidated) {
  SamplerOptions options;
  EXPECT_EQ(options.track_scan_max, 8);
  const ClassConfusionModel model = TestModel();
  const SamplerResult result = RunTest(TestOptions(1, 2000), model);
  EXPECT_TRUE(result.summary.scan_tracks.empty());
  EXPECT_EQ(result.summary.track_scan.proposed, 0);
  std::string why;
  options.track_scan_max = -1;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(why.find("scanned tracks"), std::string::npos) << why;
  options.track_scan_max = 4;
  options.track_scan_nats = -1;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(why.find("track scan"), std::string::npos) << why;
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
// frequent, so chains are sent back often; with the track scan too.
TEST(SamplerTest, SpeculativeChainsGiveTheSequentialResult) {
  const ClassConfusionModel model = TestModel();
  for (int swap_every : {1, 3}) {
    SamplerOptions options = TestOptions(3, 1500);
    options.burn_in = 100;
    options.delta_temperature = 0.3;
    options.swap_every = swap_every;
    options.cold_chain_steps = swap_every;             // and a thinned cold chain
    options.track_scan_max = swap_every == 3 ? 4 : 0;  // and the track scan
    options.track_scan_nats = std::numeric_limits<double>::infinity();
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
      EXPECT_EQ(result.summary.track_scan.accepted, reference.summary.track_scan.accepted);
      EXPECT_EQ(result.summary.track_scan.proposed, reference.summary.track_scan.proposed);
      for (int m = 0; m < kNumMoveTypes; ++m) {
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

// The sweeps after the climb end where no single change they try raises the
// target: no track moved into another object or alone at any class, no
// object switched to another class. Some candidates have no approximation
// (the test evaluator withholds a seventh) and are solved instead.
TEST(SamplerTest, SweepsEndWhereNoSingleTrackMoveOrClassSwitchImproves) {
  const ClassConfusionModel model = TestModel();
  for (int steps : {0, 5}) {
    SamplerOptions options = TestOptions(1, 2);
    options.burn_in = 0;
    options.hill_climb_steps = steps;
    options.hill_climb_patience = 0;
    options.hill_climb_sweeps = 20;
    const SamplerResult result = RunExactlyApproximated(options, model);
    const AssociationState& end = result.hill_climbed->state;
    const double end_target = TestLogTarget(end, model);
    EXPECT_EQ(result.summary.hill_climbed_log_target, end_target);
    if (steps == 0) {
      EXPECT_GT(result.summary.sweep_changes, 0);
    }
    EXPECT_LT(result.summary.sweeps, 20) << "the sweeps stop once nothing changes";
    for (int track = 0; track < 4; ++track) {
      const int from = end.BlockOf(track);
      for (size_t k = 0; k < end.blocks.size(); ++k) {
        if (static_cast<int>(k) == from) continue;
        EXPECT_LE(
            TestLogTarget(end.WithTrackMoved(track, static_cast<int>(k), end.classes[k]), model),
            end_target);
      }
      if (end.blocks[from].size() > 1) {
        for (int c = 0; c < 2; ++c)
          EXPECT_LE(TestLogTarget(end.WithTrackMoved(track, -1, c), model), end_target);
      }
    }
    for (size_t j = 0; j < end.blocks.size(); ++j) {
      AssociationState switched = end;
      switched.classes[j] = 1 - switched.classes[j];
      EXPECT_LE(TestLogTarget(switched, model), end_target);
    }
  }
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
    results.push_back(RunExactlyApproximated(options, model));
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

// A stationary AR(1) series x_t = rho x_{t-1} + e_t, e_t ~ N(0, 1).
std::vector<double> Ar1(double rho, size_t n, unsigned long seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<double> x(n);
  double previous = normal(rng) / std::sqrt(1 - rho * rho);
  for (double& v : x) previous = v = rho * previous + normal(rng);
  return x;
}

// Geyer's estimate against the known values: N for white noise,
// N (1 - rho) / (1 + rho) for AR(1). The tolerance grows with rho, as the
// estimate's spread does.
TEST(EffectiveSampleSizeTest, MatchesTheKnownValueOfAutoregressiveSeries) {
  constexpr size_t kN = 20000;
  for (unsigned long seed : {1, 2, 3}) {
    for (const auto& [rho, tolerance] : {std::pair{0.0, 0.08}, {0.5, 0.12}, {0.9, 0.2}}) {
      const double expected = kN * (1 - rho) / (1 + rho);
      const double ess = EffectiveSampleSize(Ar1(rho, kN, seed));
      EXPECT_NEAR(ess / expected, 1.0, tolerance) << "rho " << rho << ", seed " << seed;
      EXPECT_LE(ess, kN);
    }
  }
}

TEST(EffectiveSampleSizeTest, ShortOrConstantSeriesCountEveryValue) {
  EXPECT_EQ(EffectiveSampleSize({}), 0.0);
  EXPECT_EQ(EffectiveSampleSize({1.0, 5.0, 2.0}), 3.0);
  EXPECT_EQ(EffectiveSampleSize(std::vector<double>(50, 2.5)), 50.0);
}

TEST(SamplerTest, OptionsValidationNamesTheBadValue) {
  EXPECT_TRUE(SamplerOptions().Validate(nullptr));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<std::pair<std::function<void(SamplerOptions*)>, std::string>> bad = {
      {[](SamplerOptions* o) { o->hill_climb_steps = -1; }, "hill-climbing steps"},
      {[](SamplerOptions* o) { o->hill_climb_patience = -1; }, "patience"},
      {[](SamplerOptions* o) { o->hill_climb_max_steps = 10; }, "hill_climb_max_steps"},
      {[](SamplerOptions* o) { o->refine_every = 0; }, "K_NL"},
      {[](SamplerOptions* o) { o->hill_climb_screen_nats = -1; }, "screen margin"},
      {[&](SamplerOptions* o) { o->hill_climb_screen_nats = nan; }, "screen margin"},
      {[](SamplerOptions* o) {
         o->hill_climb_moves = {0.5, 0.6, 0.0};
       },
       "move probabilities"},
      {[](SamplerOptions* o) {
         o->sampling_moves = {1.2, 0.0, -0.2};
       },
       "move probabilities"},
      {[](SamplerOptions* o) {
         o->sampling_moves = {0.4, 0.4, 0.3, -0.1};
       },
       "move probabilities"},
      {[](SamplerOptions* o) { o->num_chains = 0; }, "chain"},
      {[](SamplerOptions* o) { o->cold_chain_steps = 0; }, "cold chain's steps"},
      {[](SamplerOptions* o) { o->swap_every = 0; }, "swap"},
      {[](SamplerOptions* o) { o->speculation_depth = -1; }, "speculation depth"},
      {[](SamplerOptions* o) { o->delta_temperature = -1; }, "dT"},
      {[&](SamplerOptions* o) { o->delta_temperature = inf; }, "dT"},
      {[](SamplerOptions* o) { o->num_iterations = 0; }, "iteration"},
      {[](SamplerOptions* o) { o->burn_in = -1; }, "burn-in"},
      {[](SamplerOptions* o) { o->burn_in = o->num_iterations; }, "burn-in"},
      {[](SamplerOptions* o) { o->moves.merge_sigma_m = 0; }, "sigma_E"},  // the moves' own
  };
  const ClassConfusionModel model = TestModel();
  for (const auto& [change, name] : bad) {
    SamplerOptions options;
    change(&options);
    std::string why;
    EXPECT_FALSE(options.Validate(&why)) << name;
    EXPECT_NE(why.find(name), std::string::npos) << "\"" << why << "\" does not name " << name;
    EXPECT_FALSE(options.Validate(nullptr)) << name;
    try {
      RunTest(options, model);
      ADD_FAILURE() << "Run accepted bad options: " << name;
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), "sampler options: " + why);
    }
  }
}

// The same seed gives the same run, on threads or not, with one chain or
// several; the result does not depend on the threads' timing.
TEST(SamplerTest, DeterministicFromTheSeed) {
  const ClassConfusionModel model = TestModel();
  for (int chains : {1, 3}) {
    for (bool threads : {false, true}) {
      SamplerOptions options = TestOptions(chains, 800);
      options.burn_in = 100;
      options.hill_climb_steps = 20;
      options.delta_temperature = 0.5;
      options.parallel_chains = threads;
      const SamplerResult a = RunTest(options, model, 1.0);
      const SamplerResult b = RunTest(options, model, 1.0);
      SCOPED_TRACE(std::to_string(chains) + " chains" + (threads ? " on threads" : ""));
      ASSERT_EQ(a.samples.size(), 700u);
      ASSERT_EQ(a.samples.size(), b.samples.size());
      for (size_t i = 0; i < a.samples.size(); ++i)
        ASSERT_EQ(a.samples[i]->state, b.samples[i]->state) << i;
      EXPECT_EQ(a.summary.hill_climb_trace, b.summary.hill_climb_trace);
      EXPECT_EQ(a.summary.cold_trace, b.summary.cold_trace);
      EXPECT_EQ(a.hill_climbed->state, b.hill_climbed->state);
      EXPECT_EQ(a.best->state, b.best->state);
      EXPECT_EQ(a.summary.swaps_accepted, b.summary.swaps_accepted);
      EXPECT_EQ(a.summary.num_solves, b.summary.num_solves);
      EXPECT_EQ(a.summary.effective_sample_size, b.summary.effective_sample_size);
      for (int m = 0; m < kNumMoveTypes; ++m)
        EXPECT_EQ(a.summary.sampling[m].accepted, b.summary.sampling[m].accepted);
    }
  }
}

// What the run reports: the cold chain's trace for every iteration, the
// samples after the burn-in, each completed once per distinct state by an
// evaluator of its own, the best state seen, one swap proposal per adjacent
// pair and swap interval.
TEST(SamplerTest, RecordsTheColdChainAfterTheBurnIn) {
  const ClassConfusionModel model = TestModel();
  SamplerOptions options = TestOptions(3, 301);
  options.burn_in = 50;
  options.swap_every = 4;
  std::vector<std::shared_ptr<TestEvaluator::Counts>> counts;  // by creation
  Sampler sampler(
      model,
      [&] {
        auto evaluator = std::make_unique<TestEvaluator>(model);
        counts.push_back(std::make_shared<TestEvaluator::Counts>());
        evaluator->CountInto(counts.back());
        return evaluator;
      },
      options);
  const SamplerResult result = sampler.Run(SeparateTracksState(kTrackClass));
  const SamplerSummary& summary = result.summary;
  ASSERT_EQ(counts.size(), 4u);  // three chains and the completer
  ASSERT_EQ(summary.cold_trace.size(), 301u);
  ASSERT_EQ(result.samples.size(), 251u);
  std::unordered_map<AssociationState, EvaluationPtr, AssociationStateHash> completed;
  for (size_t i = 0; i < result.samples.size(); ++i) {
    const EvaluationPtr& sample = result.samples[i];
    EXPECT_EQ(sample->evaluation_time_s, 1.0) << "not completed: " << i;
    EXPECT_EQ(sample->log_target, summary.cold_trace[50 + i]);
    EXPECT_EQ(sample->log_target, TestLogTarget(sample->state, model));
    EvaluationPtr& first = completed[sample->state];
    if (!first) first = sample;
    EXPECT_EQ(sample, first) << "completed twice: " << sample->state.ToString();
  }
  EXPECT_EQ(counts[3]->completions, static_cast<int>(completed.size()));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(counts[i]->completions, 0);

  double best = result.hill_climbed->log_target;
  for (double v : summary.cold_trace) best = std::max(best, v);
  EXPECT_EQ(result.best->log_target, best);
  EXPECT_EQ(result.hill_climbed->log_target, summary.hill_climbed_log_target);
  EXPECT_EQ(summary.swaps_proposed, 2 * 76);  // 2 pairs, ceil(301 / 4) intervals
  EXPECT_GT(summary.swaps_accepted, 0);
  long proposed = 0;
  for (const MoveStatistics& m : summary.sampling) proposed += m.proposed;
  EXPECT_EQ(proposed, 301);  // the cold chain's, one per iteration
  size_t solves = 0;
  for (const auto& c : counts) solves += c->solves;
  EXPECT_EQ(summary.num_solves, solves);
  EXPECT_GT(summary.effective_sample_size, 0);
  EXPECT_LE(summary.effective_sample_size, 251);
  EXPECT_EQ(summary.message, "ok");
}

// An evaluator that throws in a chain's thread (or between swap decisions)
// ends the run with its error, whether the chains run ahead, in lock-step or
// one after another.
TEST(SamplerTest, AChainsErrorEndsTheRun) {
  const ClassConfusionModel model = TestModel();
  for (int failing : {0, 2}) {
    for (const auto& [threads, depth] : {std::pair{true, 8}, {true, 0}, {false, 0}}) {
      SamplerOptions options = TestOptions(3, 2000);
      options.burn_in = 10;
      options.delta_temperature = 0.3;
      options.parallel_chains = threads;
      options.speculation_depth = depth;
      int created = 0;
      Sampler sampler(
          model,
          [&] {
            auto evaluator = std::make_unique<TestEvaluator>(model);
            if (created++ == failing) evaluator->FailAfterSolves(15);
            return evaluator;
          },
          options);
      SCOPED_TRACE("chain " + std::to_string(failing) + (threads ? " on threads" : "") +
                   ", depth " + std::to_string(depth));
      try {
        sampler.Run(SeparateTracksState(kTrackClass));
        ADD_FAILURE() << "the run ended without the evaluator's error";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("failing as asked"), std::string::npos) << e.what();
      }
    }
  }
}

TEST(SamplerTest, AnUnevaluableStartIsAnError) {
  class Unevaluable : public TestEvaluator {
   public:
    using TestEvaluator::TestEvaluator;
    EvaluationPtr Refine(const AssociationState& state, const StateEvaluation*) override {
      auto e = std::make_shared<StateEvaluation>();
      e->state = state;
      return e;  // not valid
    }
  };
  const ClassConfusionModel model = TestModel();
  Sampler sampler(
      model, [&] { return std::make_unique<Unevaluable>(model); }, TestOptions(1, 2000));
  try {
    sampler.Run(SeparateTracksState(kTrackClass));
    ADD_FAILURE() << "an unevaluable start was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("start state"), std::string::npos) << e.what();
  }
}

// A greedy step returns the current state or one with a higher target,
// never a lower one; a tempered step from the same draws does accept
// decreases, so the rule is what makes the difference.
TEST(MetropolisStepTest, GreedyAcceptsOnlyIncreases) {
  const ClassConfusionModel model = TestModel();
  const MoveOptions moves;
  const MoveProbabilities probabilities{0.4, 0.4, 0.2};
  StepRule greedy;
  greedy.greedy = true;
  const StepRule tempered;  // beta 1, no screen
  long greedy_accepted = 0, decreases_accepted = 0;
  for (const AssociationState& state : testing::EnumerateStates(4, 2)) {
    TestEvaluator evaluator(model);
    const EvaluationPtr current = evaluator.Evaluate(state, nullptr);
    for (unsigned long seed = 0; seed < 20; ++seed) {
      std::array<MoveStatistics, kNumMoveTypes> stats{};
      Rng rng(seed);
      const EvaluationPtr next =
          MetropolisStep(current, greedy, evaluator, model, moves, probabilities, rng, &stats);
      long accepted = 0;
      for (const MoveStatistics& m : stats) accepted += m.accepted;
      if (next == current) {
        EXPECT_EQ(accepted, 0);
      } else {
        EXPECT_GT(next->log_target, current->log_target) << state.ToString();
        EXPECT_EQ(accepted, 1);
        ++greedy_accepted;
      }
      Rng same(seed);
      const EvaluationPtr sampled =
          MetropolisStep(current, tempered, evaluator, model, moves, probabilities, same, &stats);
      if (sampled != current && sampled->log_target < current->log_target) ++decreases_accepted;
    }
  }
  EXPECT_GT(greedy_accepted, 100);
  EXPECT_GT(decreases_accepted, 50);
}

// A proposal whose evaluation fails is rejected, and counted as proposed.
TEST(MetropolisStepTest, RejectsAnInvalidEvaluation) {
  class Invalid : public TestEvaluator {
   public:
    using TestEvaluator::TestEvaluator;
    EvaluationPtr Evaluate(const AssociationState& state, const StateEvaluation*) override {
      auto e = std::make_shared<StateEvaluation>();
      e->state = state;
      return e;  // not valid
    }
  };
  const ClassConfusionModel model = TestModel();
  Invalid evaluator(model);
  const EvaluationPtr current = testing::TestEvaluation(SeparateTracksState(kTrackClass), model);
  std::array<MoveStatistics, kNumMoveTypes> stats{};
  Rng rng(5);
  for (int k = 0; k < 50; ++k)
    EXPECT_EQ(MetropolisStep(current, StepRule{}, evaluator, model, MoveOptions{}, {0.4, 0.4, 0.2},
                             rng, &stats),
              current);
  long proposed = 0, accepted = 0, self_transitions = 0;
  for (const MoveStatistics& m : stats) {
    proposed += m.proposed;
    accepted += m.accepted;
    self_transitions += m.self_transitions;
  }
  EXPECT_EQ(proposed, 50);
  EXPECT_EQ(accepted, 0);
  EXPECT_LT(self_transitions, 40);  // most were evaluated, and rejected
}

}  // namespace
}  // namespace oslam
