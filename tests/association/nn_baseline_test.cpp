// The nearest-neighbour baseline (nn_baseline.h): tracks taken in time order
// join the nearest object of their class whose running mean location is
// within the gate, else start one; on the synthetic loop it recovers the true
// association from the all-separate solve when the gate is below the spacing
// of the objects.
#include "association/nn_baseline.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "association/scene_tracks.h"
#include "core/error.h"

namespace oslam {
namespace {

// The all-separate evaluation of tracks at `locations` with `classes`.
StateEvaluation Separate(const std::vector<Eigen::Vector3d>& locations,
                         const std::vector<int>& classes) {
  StateEvaluation e;
  e.state = SeparateTracksState(classes);
  e.valid = true;
  e.locations = locations;
  e.residual2.assign(locations.size(), 1.0);
  return e;
}

AssociationState State(std::vector<std::vector<int>> blocks, std::vector<int> classes) {
  AssociationState s{std::move(blocks), std::move(classes)};
  s.Canonicalize();
  return s;
}

NearestNeighbourOptions Gate(double gate_m) {
  NearestNeighbourOptions options;
  options.gate_m = gate_m;
  return options;
}

TEST(NearestNeighbourTest, JoinsNearTracksOfOneClassOnly) {
  // Tracks 0 and 1 are 0.3 m apart; track 2 is as near but of another
  // class; track 3 is 1 m away.
  const StateEvaluation separate =
      Separate({{0.0, 0.0, 0.0}, {0.3, 0.0, 0.0}, {0.2, 0.1, 0.0}, {1.3, 0.0, 0.0}}, {0, 0, 1, 0});
  EXPECT_EQ(NearestNeighbourAssociation(separate, Gate(0.5)), State({{0, 1}, {2}, {3}}, {0, 1, 0}));
  // A gate wider than every distance joins each class into one object.
  EXPECT_EQ(NearestNeighbourAssociation(separate, Gate(5.0)), State({{0, 1, 3}, {2}}, {0, 1}));
  // A gate narrower than every distance keeps the tracks apart.
  EXPECT_EQ(NearestNeighbourAssociation(separate, Gate(0.1)), separate.state);
}

TEST(NearestNeighbourTest, GatesOnTheObjectsMeanLocationNotOnItsLatestTrack) {
  // In a line 0.4 m apart: track 1 joins track 0 (0.4 < 0.5); the object's
  // mean is then at 0.2, so track 2 (0.6 from it, 0.4 from track 1) starts a
  // new object: no chaining along the line.
  const StateEvaluation line =
      Separate({{0.0, 0.0, 0.0}, {0.4, 0.0, 0.0}, {0.8, 0.0, 0.0}, {1.2, 0.0, 0.0}}, {0, 0, 0, 0});
  EXPECT_EQ(NearestNeighbourAssociation(line, Gate(0.5)), State({{0, 1}, {2, 3}}, {0, 0}));
}

TEST(NearestNeighbourTest, ATrackJoinsTheNearestOfSeveralObjectsInTheGate) {
  // Objects started by tracks 0 (x = 0) and 1 (x = 1); track 2 at x = 0.55
  // is within the gate of both and nearer to the second.
  const StateEvaluation separate =
      Separate({{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.55, 0.0, 0.0}}, {1, 1, 1});
  EXPECT_EQ(NearestNeighbourAssociation(separate, Gate(0.6)), State({{0}, {1, 2}}, {1, 1}));
  // Time order decides: moved to x = 0.45, it joins the first.
  const StateEvaluation nearer_first =
      Separate({{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.45, 0.0, 0.0}}, {1, 1, 1});
  EXPECT_EQ(NearestNeighbourAssociation(nearer_first, Gate(0.6)), State({{0, 2}, {1}}, {1, 1}));
}

TEST(NearestNeighbourTest, TheGateIsAStrictBoundAndMeasuredIn3d) {
  // 0.625 m apart, in y and z (a 3-4-5 triangle, exact in binary): exactly
  // at the gate is outside it.
  const StateEvaluation at_gate = Separate({{0.0, 0.0, 0.0}, {0.0, 0.375, 0.5}}, {0, 0});
  EXPECT_EQ(NearestNeighbourAssociation(at_gate, Gate(0.625)), at_gate.state);
  EXPECT_EQ(NearestNeighbourAssociation(at_gate, Gate(0.626)), State({{0, 1}}, {0}));
  // Height counts: 0.5 m above is beyond a 0.45 m gate although the floor
  // positions coincide.
  const StateEvaluation above = Separate({{1.0, 2.0, 0.0}, {1.0, 2.0, 0.5}}, {0, 0});
  EXPECT_EQ(NearestNeighbourAssociation(above, Gate(0.45)), above.state);
}

TEST(NearestNeighbourTest, ResultIsCanonicalAndCoversEveryTrackOnce) {
  std::vector<Eigen::Vector3d> locations;
  std::vector<int> classes;
  for (int t = 0; t < 40; ++t) {
    locations.emplace_back(std::sin(1.7 * t), std::cos(2.3 * t), 0.1 * (t % 3));
    classes.push_back(t % 3);
  }
  const AssociationState state =
      NearestNeighbourAssociation(Separate(locations, classes), Gate(0.6));
  AssociationState canonical = state;
  canonical.Canonicalize();
  EXPECT_EQ(state, canonical);
  std::vector<int> seen(40, 0);
  for (size_t j = 0; j < state.blocks.size(); ++j)
    for (int t : state.blocks[j]) {
      ++seen[t];
      EXPECT_EQ(state.classes[j], classes[t]) << "track " << t << " changed class";
    }
  EXPECT_EQ(seen, std::vector<int>(40, 1));
  EXPECT_LT(state.blocks.size(), 40u);
  EXPECT_GT(state.blocks.size(), 3u);
}

TEST(NearestNeighbourTest, TheGateMustBeAPositiveFiniteDistance) {
  for (double gate : {0.0, -0.5, std::numeric_limits<double>::infinity(),
                      std::numeric_limits<double>::quiet_NaN()}) {
    std::string why;
    EXPECT_FALSE(Gate(gate).Validate(&why)) << gate;
    EXPECT_NE(why.find("gate"), std::string::npos) << why;
    EXPECT_FALSE(Gate(gate).Validate(nullptr));
    const StateEvaluation separate = Separate({{0.0, 0.0, 0.0}}, {0});
    EXPECT_THROW(NearestNeighbourAssociation(separate, Gate(gate)), Error) << gate;
  }
  EXPECT_TRUE(Gate(0.5).Validate(nullptr));
}

// The baseline as the slam command runs it: the all-separate state solved
// fully, then gated. Taken in time order, if every track is nearer than the
// gate to the running mean of its object's earlier tracks, and farther from
// every other object's of its class, the result is the true association.
TEST(NearestNeighbourTest, RecoversTheTrueAssociationOnTheSyntheticLoop) {
  const testing::SceneTracks s = testing::MakeSceneTracks();
  ASSERT_GT(s.data.tracks.size(), 2 * s.truth.blocks.size());
  const ClassConfusionModel model = s.Model();
  SlamTargetOptions options;
  options.slam.pixel_std_px = 3.0;
  SlamEvaluator evaluator(s.data, model, options);
  const EvaluationPtr separate = evaluator.Refine(s.Separate(), nullptr);
  ASSERT_TRUE(separate->valid);
  // Running means of the true objects' tracks, in time order: how near each
  // track comes to its own object and to the others of its class.
  std::map<int, std::pair<Eigen::Vector3d, int>> sums;  // object -> (sum, count)
  double own = 0, other = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t < s.track_object.size(); ++t) {
    for (const auto& [object, sum] : sums) {
      if (s.scene.problem.object_class.at(object) != s.track_class[t]) continue;
      const double d = (sum.first / sum.second - separate->locations[t]).norm();
      if (object == s.track_object[t])
        own = std::max(own, d);
      else
        other = std::min(other, d);
    }
    auto& sum = sums.try_emplace(s.track_object[t], Eigen::Vector3d::Zero(), 0).first->second;
    sum.first += separate->locations[t];
    ++sum.second;
  }
  std::printf("tracks up to %.2f m from their object, at least %.2f m from others\n", own, other);
  ASSERT_LT(own + 0.2, other);
  for (double gate : {own + 0.05, 0.5 * (own + other), other - 0.05})
    EXPECT_EQ(NearestNeighbourAssociation(*separate, Gate(gate)), s.truth) << gate;
  // A gate below that leaves an object in pieces.
  EXPECT_GT(NearestNeighbourAssociation(*separate, Gate(own - 0.05)).blocks.size(),
            s.truth.blocks.size());
  // A gate wider than the loop merges the objects of each class.
  const AssociationState wide = NearestNeighbourAssociation(*separate, Gate(10.0));
  EXPECT_EQ(wide.blocks.size(), 2u) << wide.ToString();
}

}  // namespace
}  // namespace oslam
