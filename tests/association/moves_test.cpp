// The merge, split, switch and reassign proposals (moves.h) on the enumerable 4-track,
// 2-class problem: how often each state is proposed, counted over many
// draws, must match the move's forward probability, and the reverse
// probability must be the forward probability of the move that undoes it.
#include "association/moves.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <unordered_map>

#include <gtest/gtest.h>

#include "association/association_fixture.h"

namespace oslam {
namespace {

using testing::TestEvaluation;
using testing::TestModel;

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

AssociationState State(std::vector<std::vector<int>> blocks, std::vector<int> classes) {
  AssociationState state{std::move(blocks), std::move(classes)};
  state.Canonicalize();
  return state;
}

// A proposed state and the path that proposed it: merge and reassign (a
// track alone joining an object), split and reassign (one track leaving
// alone) can propose the same state, and so can two reassigns that move
// different tracks ({0} {1} -> {0, 1}), each with its own probability. A
// reassign's reverse is the path that moves the same track back.
struct MoveKey {
  MoveType type;
  AssociationState state;
  int moved_track = -1;  // reassign only
  bool operator==(const MoveKey& other) const {
    return type == other.type && state == other.state && moved_track == other.moved_track;
  }
};
MoveKey KeyOf(const Proposal& p, const AssociationState& state) {
  return {p.type, state, p.type == MoveType::kReassign ? p.track : -1};
}
// The path back: a split undoes a merge and a merge a split; switch and
// reassign undo themselves.
MoveKey ReverseKeyOf(const Proposal& p, const AssociationState& state) {
  MoveKey key = KeyOf(p, state);
  if (p.type == MoveType::kMerge) key.type = MoveType::kSplit;
  if (p.type == MoveType::kSplit) key.type = MoveType::kMerge;
  return key;
}
struct MoveKeyHash {
  size_t operator()(const MoveKey& key) const {
    return (AssociationStateHash()(key.state) * 31 + static_cast<size_t>(key.type)) * 31 +
           static_cast<size_t>(key.moved_track + 1);
  }
};

// What drawing `n` proposals from one state gave: per move and distinct
// proposed state how often it came and one proposal that led there.
struct Tally {
  struct Outcome {
    long count = 0;
    Proposal proposal;
  };
  std::unordered_map<MoveKey, Outcome, MoveKeyHash> outcomes;
  long self_transitions = 0;
  long n = 0;
};

Tally Draw(const StateEvaluation& from, const ClassConfusionModel& model,
           const MoveOptions& options, const MoveProbabilities& probabilities, long n,
           unsigned long seed) {
  Rng rng(seed);
  Tally tally;
  tally.n = n;
  for (long k = 0; k < n; ++k) {
    Proposal p = ProposeMove(from, model, options, probabilities, rng);
    if (p.self_transition) {
      ++tally.self_transitions;
      continue;
    }
    Tally::Outcome& outcome = tally.outcomes[KeyOf(p, p.state)];
    // The same proposed state must always come with the same probability
    // (a merge's two orders are summed in either order: equal to rounding).
    if (outcome.count > 0) {
      EXPECT_NEAR(p.log_q_forward, outcome.proposal.log_q_forward, 1e-12) << p.state.ToString();
    }
    if (outcome.count++ == 0) outcome.proposal = std::move(p);
  }
  return tally;
}

// A frequency within 5 binomial standard deviations of p (plus a little for
// the rare ones).
void ExpectFrequency(long count, long n, double p, const std::string& what) {
  const double frequency = static_cast<double>(count) / n;
  p = std::clamp(p, 0.0, 1.0);  // 1 - sum of probabilities may round below 0
  const double sigma = std::sqrt(p * (1 - p) / n);
  EXPECT_NEAR(frequency, p, 5 * sigma + 2e-4) << what;
}

struct Case {
  const char* name;
  AssociationState state;
  MoveOptions options;
};

std::vector<Case> Cases() {
  MoveOptions thesis;
  thesis.split_sampler = SplitSampler::kThesis;
  thesis.merge_count_includes_self = true;
  thesis.merge_count_smoothing = 0;
  MoveOptions strict;  // never merge across classes, no uniform class share
  strict.class_mismatch_penalty = std::numeric_limits<double>::infinity();
  strict.class_proposal_uniform = 0;
  return {
      {"all separate", SeparateTracksState(testing::kTrackClass), MoveOptions{}},
      {"three and one", State({{0, 1, 3}, {2}}, {0, 1}), MoveOptions{}},
      {"three and one, thesis split", State({{0, 1, 3}, {2}}, {0, 1}), thesis},
      {"two and two, strict", State({{0, 2}, {1, 3}}, {1, 0}), strict},
      {"all in one, thesis split", State({{0, 1, 2, 3}}, {0}), thesis},
  };
}

// The forward probability against an independent count: every state a
// move can reach is proposed as often as exp(log q_fwd) says, and what is
// left is the self-transitions.
TEST(MovesTest, ProposalFrequenciesMatchTheForwardProbability) {
  const ClassConfusionModel model = TestModel();
  const MoveProbabilities probabilities{0.3, 0.3, 0.2, 0.2};
  constexpr long kDraws = 200000;
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.name);
    const EvaluationPtr from = TestEvaluation(c.state, model);
    const Tally tally = Draw(*from, model, c.options, probabilities, kDraws, 11);
    EXPECT_GT(tally.outcomes.size(), 2u);
    double total = 0;
    for (const auto& [key, outcome] : tally.outcomes) {
      const AssociationState& state = key.state;
      const double q = std::exp(outcome.proposal.log_q_forward);
      ExpectFrequency(outcome.count, kDraws, q, state.ToString());
      total += q;
    }
    ExpectFrequency(tally.self_transitions, kDraws, 1.0 - total, "self-transitions");
  }
}

// The probability a proposal reports is the one LogForwardProbability
// computes on the state's own evaluation (delayed acceptance relies on it).
TEST(MovesTest, ForwardProbabilityOnTheOwnEvaluationIsTheProposals) {
  const ClassConfusionModel model = TestModel();
  const MoveProbabilities probabilities{0.3, 0.3, 0.2, 0.2};
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.name);
    const EvaluationPtr from = TestEvaluation(c.state, model);
    const Tally tally = Draw(*from, model, c.options, probabilities, 5000, 12);
    for (const auto& [key, outcome] : tally.outcomes)
      EXPECT_DOUBLE_EQ(
          LogForwardProbability(outcome.proposal, *from, model, c.options, probabilities),
          outcome.proposal.log_q_forward)
          << key.state.ToString();
  }
}

// Merge then split back (and split then merge, switch then switch back):
// log q_rev(x -> y), computed on y's evaluation, is the forward probability
// of the proposal y -> x, and y proposes x as often as it says.
TEST(MovesTest, ReverseProbabilityIsTheForwardProbabilityOfTheMoveBack) {
  const ClassConfusionModel model = TestModel();
  const MoveProbabilities probabilities{0.3, 0.3, 0.2, 0.2};
  std::array<int, kNumMoveTypes> checked{};
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.name);
    const EvaluationPtr x = TestEvaluation(c.state, model);
    const Tally forward = Draw(*x, model, c.options, probabilities, 20000, 13);
    for (const auto& [key, outcome] : forward.outcomes) {
      const AssociationState& state = key.state;
      const EvaluationPtr y = TestEvaluation(state, model);
      const double log_reverse =
          LogReverseProbability(outcome.proposal, *y, model, c.options, probabilities);
      if (log_reverse == kNegInf) continue;  // checked in ImpossibleReverseMoves
      const Tally back = Draw(*y, model, c.options, probabilities, 10000, 14);
      const auto found = back.outcomes.find(ReverseKeyOf(outcome.proposal, c.state));
      if (found == back.outcomes.end()) {  // then the way back must be rare
        EXPECT_LT(std::exp(log_reverse) * back.n, 3.0) << state.ToString();
        continue;
      }
      EXPECT_NEAR(log_reverse, found->second.proposal.log_q_forward, 1e-12) << state.ToString();
      ExpectFrequency(found->second.count, back.n, std::exp(log_reverse), state.ToString());
      ++checked[static_cast<int>(outcome.proposal.type)];
    }
  }
  for (int m = 0; m < kNumMoveTypes; ++m)
    EXPECT_GT(checked[m], 2) << MoveName(static_cast<MoveType>(m));
}

// Proposed states are canonical and differ from the current one exactly as
// the move says; the parts and old classes the reverse move needs are right.
TEST(MovesTest, ProposalsAreCanonicalAndChangeWhatTheMoveSays) {
  const ClassConfusionModel model = TestModel();
  const MoveProbabilities probabilities{0.3, 0.3, 0.2, 0.2};
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.name);
    const EvaluationPtr from = TestEvaluation(c.state, model);
    const AssociationState& x = c.state;
    const Tally tally = Draw(*from, model, c.options, probabilities, 5000, 15);
    for (const auto& [key, outcome] : tally.outcomes) {
      const AssociationState& state = key.state;
      const Proposal& p = outcome.proposal;
      SCOPED_TRACE(std::string(MoveName(p.type)) + " to " + state.ToString());
      AssociationState canonical = p.state;
      canonical.Canonicalize();
      EXPECT_EQ(canonical, p.state);
      EXPECT_EQ(p.state.num_tracks(), x.num_tracks());
      for (int cls : p.state.classes) EXPECT_TRUE(cls == 0 || cls == 1);
      EXPECT_FALSE(p.state == x);
      switch (p.type) {
        case MoveType::kMerge: {
          ASSERT_EQ(p.state.blocks.size(), x.blocks.size() - 1);
          std::vector<int> merged = p.part_a;
          merged.insert(merged.end(), p.part_b.begin(), p.part_b.end());
          std::sort(merged.begin(), merged.end());
          EXPECT_EQ(p.state.blocks[p.state.BlockOf(p.part_a.front())], merged);
          EXPECT_EQ(x.blocks[x.BlockOf(p.part_a.front())], p.part_a);
          EXPECT_EQ(x.blocks[x.BlockOf(p.part_b.front())], p.part_b);
          EXPECT_EQ(x.classes[x.BlockOf(p.part_a.front())], p.old_class_a);
          EXPECT_EQ(x.classes[x.BlockOf(p.part_b.front())], p.old_class_b);
          break;
        }
        case MoveType::kSplit: {
          ASSERT_EQ(p.state.blocks.size(), x.blocks.size() + 1);
          EXPECT_LT(p.part_a.front(), p.part_b.front());  // the earliest track stays first
          EXPECT_EQ(p.state.blocks[p.state.BlockOf(p.part_a.front())], p.part_a);
          EXPECT_EQ(p.state.blocks[p.state.BlockOf(p.part_b.front())], p.part_b);
          const int old = x.BlockOf(p.part_a.front());
          EXPECT_EQ(x.BlockOf(p.part_b.front()), old);
          EXPECT_EQ(x.blocks[old].size(), p.part_a.size() + p.part_b.size());
          EXPECT_EQ(x.classes[old], p.old_class_a);
          break;
        }
        case MoveType::kSwitch: {
          ASSERT_EQ(p.state.blocks, x.blocks);
          int changed = 0;
          for (size_t j = 0; j < x.classes.size(); ++j)
            changed += x.classes[j] != p.state.classes[j];
          EXPECT_EQ(changed, 1);
          EXPECT_EQ(x.classes[x.BlockOf(p.track)], p.old_class_a);
          EXPECT_NE(p.state.classes[p.state.BlockOf(p.track)], p.old_class_a);
          break;
        }
        case MoveType::kReassign: {
          // The track left its object for part_b's object or alone (both
          // objects draw their classes); nothing else moved. The old classes
          // are kept for the reverse move.
          const int from = x.BlockOf(p.track);
          EXPECT_EQ(x.classes[from], p.old_class_a);
          std::vector<int> rest = x.blocks[from];
          rest.erase(std::find(rest.begin(), rest.end(), p.track));
          EXPECT_EQ(p.part_a, rest);
          if (!rest.empty()) {
            EXPECT_EQ(p.state.blocks[p.state.BlockOf(rest.front())], rest);
          }
          const int to = p.state.BlockOf(p.track);
          std::vector<int> joined = p.part_b;
          joined.push_back(p.track);
          std::sort(joined.begin(), joined.end());
          EXPECT_EQ(p.state.blocks[to], joined);
          if (!p.part_b.empty()) {
            EXPECT_EQ(x.blocks[x.BlockOf(p.part_b.front())], p.part_b);
            EXPECT_EQ(p.old_class_b, x.classes[x.BlockOf(p.part_b.front())]);
          }
          for (size_t j = 0; j < x.blocks.size(); ++j) {
            if (x.blocks[j] == x.blocks[from] || x.blocks[j] == p.part_b) continue;
            const int same = p.state.BlockOf(x.blocks[j].front());
            EXPECT_EQ(p.state.blocks[same], x.blocks[j]);
            EXPECT_EQ(p.state.classes[same], x.classes[j]);
          }
          EXPECT_EQ(p.state.blocks.size(),
                    x.blocks.size() + (p.part_b.empty() ? 1 : 0) - (rest.empty() ? 1 : 0));
          break;
        }
      }
    }
  }
}

TEST(MovesTest, ImpossibleMovesAreSelfTransitions) {
  const ClassConfusionModel model = TestModel();
  const MoveOptions options;
  Rng rng(16);
  auto propose = [&](const AssociationState& state, const MoveProbabilities& probabilities) {
    return ProposeMove(*TestEvaluation(state, model), model, options, probabilities, rng);
  };
  const AssociationState one = State({{0, 1, 2, 3}}, {0});
  const AssociationState separate = SeparateTracksState(testing::kTrackClass);
  for (int k = 0; k < 20; ++k) {
    const Proposal merge = propose(one, {1, 0, 0});  // nothing to merge with
    EXPECT_EQ(merge.type, MoveType::kMerge);
    EXPECT_TRUE(merge.self_transition);
    const Proposal split = propose(separate, {0, 1, 0});  // single tracks only
    EXPECT_EQ(split.type, MoveType::kSplit);
    EXPECT_TRUE(split.self_transition);
  }
  // Never across classes: two objects of different classes cannot merge.
  MoveOptions strict;
  strict.class_mismatch_penalty = std::numeric_limits<double>::infinity();
  const AssociationState two = State({{0, 1}, {2, 3}}, {0, 1});
  for (int k = 0; k < 20; ++k)
    EXPECT_TRUE(
        ProposeMove(*TestEvaluation(two, model), model, strict, {1, 0, 0}, rng).self_transition);
  // Reassign: a track alone has nowhere to go when every other object is of
  // another class and merging across classes is forbidden.
  const AssociationState lone = State({{0}, {1, 2, 3}}, {0, 1});
  const EvaluationPtr lone_evaluation = TestEvaluation(lone, model);
  int lone_track_drawn = 0;
  for (int k = 0; k < 200; ++k) {
    const Proposal p = ProposeMove(*lone_evaluation, model, strict, {0, 0, 0, 1}, rng);
    EXPECT_EQ(p.type, MoveType::kReassign);
    if (p.self_transition) {
      ++lone_track_drawn;
      continue;
    }
    EXPECT_NE(p.track, 0);  // tracks of the big object may go alone
    EXPECT_TRUE(p.part_b.empty());
  }
  EXPECT_GT(lone_track_drawn, 20);  // about 1 in 4
  EXPECT_EQ(LogReassignProbability(*lone_evaluation, 0, 1, 0, 0, model, strict, {0, 0, 0, 1}),
            kNegInf);
}

// A split whose halves get different classes cannot be undone when merging
// across classes is forbidden: its reverse probability is zero.
TEST(MovesTest, ImpossibleReverseMoves) {
  const ClassConfusionModel model = TestModel();
  MoveOptions strict;
  strict.class_mismatch_penalty = std::numeric_limits<double>::infinity();
  const MoveProbabilities probabilities{0.4, 0.4, 0.2};
  const AssociationState one = State({{0, 1, 2, 3}}, {0});
  const Tally tally = Draw(*TestEvaluation(one, model), model, strict, probabilities, 5000, 17);
  int impossible = 0, possible = 0;
  for (const auto& [key, outcome] : tally.outcomes) {
    const AssociationState& state = key.state;
    if (outcome.proposal.type != MoveType::kSplit) continue;
    const double log_reverse = LogReverseProbability(
        outcome.proposal, *TestEvaluation(state, model), model, strict, probabilities);
    if (state.classes[0] != state.classes[1]) {
      EXPECT_EQ(log_reverse, kNegInf) << state.ToString();
      ++impossible;
    } else {
      EXPECT_GT(log_reverse, kNegInf) << state.ToString();
      ++possible;
    }
  }
  EXPECT_GT(impossible, 0);
  EXPECT_GT(possible, 0);
}

// q(c) = (1 - u) prod P(a | c) / Z + u / |classes|: the uniform share keeps
// a class the tracks' detections speak against within reach (seen on the
// class a merge draws).
TEST(MovesTest, ClassProposalMixesInTheUniformShare) {
  const ClassConfusionModel model = TestModel();
  const MoveProbabilities probabilities{0.4, 0.4, 0.2};
  const AssociationState one = State({{0, 1, 3}, {2}}, {0, 1});
  const EvaluationPtr e = TestEvaluation(one, model);
  const double data = std::exp(model.ClassLogProposal({0, 1, 2, 3})[1]);
  ASSERT_LT(data, 0.05);  // three of the four tracks were reported as class 0
  MoveOptions options;
  options.class_proposal_uniform = 0;
  const double without = LogMergeProbability(*e, 0, 1, 1, model, options, probabilities);
  options.class_proposal_uniform = 0.1;
  const double with = LogMergeProbability(*e, 0, 1, 1, model, options, probabilities);
  EXPECT_NEAR(with - without, std::log((0.9 * data + 0.05) / data), 1e-9);
}

// The switch draws among the other classes only, q(c') / (1 - q(c_j)): with
// two classes it always proposes the other one, and never the current one.
TEST(MovesTest, SwitchNeverProposesTheCurrentClass) {
  const ClassConfusionModel model = TestModel();
  const MoveProbabilities probabilities{0.4, 0.4, 0.2};
  const AssociationState one = State({{0, 1, 3}, {2}}, {0, 1});
  const EvaluationPtr e = TestEvaluation(one, model);
  const MoveOptions options;
  EXPECT_EQ(LogSwitchProbability(*e, 0, 0, model, options, probabilities), kNegInf);
  const double to_other = LogSwitchProbability(*e, 0, 1, model, options, probabilities);
  const double block_term = to_other - std::log(0.2);
  EXPECT_LE(block_term, 0.0);
  // Only the block draw is left: both blocks' switch probabilities sum to P_switch.
  const double other_block = LogSwitchProbability(*e, 1, 0, model, options, probabilities);
  EXPECT_NEAR(std::exp(to_other) + std::exp(other_block), 0.2, 1e-12);
}

TEST(MovesTest, OptionsValidationNamesTheBadValue) {
  EXPECT_TRUE(MoveOptions().Validate(nullptr));
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::pair<std::function<void(MoveOptions*)>, std::string>> bad = {
      {[](MoveOptions* o) { o->merge_distance_m = 0; }, "merge distance"},
      {[&](MoveOptions* o) { o->merge_distance_m = nan; }, "merge distance"},
      {[](MoveOptions* o) { o->merge_sigma_m = 0; }, "sigma_E"},
      {[&](MoveOptions* o) { o->merge_sigma_m = inf; }, "sigma_E"},
      {[](MoveOptions* o) { o->class_mismatch_penalty = 0.5; }, "class-mismatch penalty"},
      {[](MoveOptions* o) { o->merge_count_smoothing = -0.1; }, "merge count smoothing"},
      {[&](MoveOptions* o) { o->merge_count_smoothing = inf; }, "merge count smoothing"},
      {[](MoveOptions* o) { o->class_proposal_uniform = 1; }, "uniform share"},
      {[](MoveOptions* o) { o->reassign_sigma_m = 0; }, "sigma_R"},
      {[&](MoveOptions* o) { o->reassign_sigma_m = inf; }, "sigma_R"},
      {[](MoveOptions* o) { o->class_proposal_uniform = -0.1; }, "uniform share"},
  };
  for (const auto& [change, name] : bad) {
    MoveOptions options;
    change(&options);
    std::string why;
    EXPECT_FALSE(options.Validate(&why)) << name;
    EXPECT_NE(why.find(name), std::string::npos) << "\"" << why << "\" does not name " << name;
    EXPECT_FALSE(options.Validate(nullptr)) << name;
  }
  MoveOptions never_across_classes;
  never_across_classes.class_mismatch_penalty = inf;
  EXPECT_TRUE(never_across_classes.Validate(nullptr));
}

TEST(MovesTest, MoveNames) {
  EXPECT_STREQ(MoveName(MoveType::kMerge), "merge");
  EXPECT_STREQ(MoveName(MoveType::kSplit), "split");
  EXPECT_STREQ(MoveName(MoveType::kSwitch), "switch");
  EXPECT_STREQ(MoveName(MoveType::kReassign), "reassign");
}

}  // namespace
}  // namespace oslam
