// The O-Map evaluation (oslam eval, run, slam, map) on constructed maps with
// known answers.
#include "omap/evaluation.h"

#include <algorithm>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include "core/error.h"

namespace oslam {
namespace {

double AssignmentCost(const std::vector<std::vector<double>>& cost, const std::vector<int>& a) {
  double total = 0;
  for (size_t r = 0; r < a.size(); ++r)
    if (a[r] >= 0) total += cost[r][a[r]];
  return total;
}

TEST(MinCostAssignment, MatchesBruteForceOnRandomSquareProblems) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> uniform(0.0, 10.0);
  for (int trial = 0; trial < 50; ++trial) {
    const int n = 1 + trial % 6;
    std::vector<std::vector<double>> cost(n, std::vector<double>(n));
    for (auto& row : cost)
      for (double& c : row) c = uniform(rng);
    const std::vector<int> assignment = MinCostAssignment(cost, 1e9);
    std::vector<int> permutation(n);
    std::iota(permutation.begin(), permutation.end(), 0);
    double best = 1e18;
    do {
      best = std::min(best, AssignmentCost(cost, permutation));
    } while (std::next_permutation(permutation.begin(), permutation.end()));
    EXPECT_NEAR(AssignmentCost(cost, assignment), best, 1e-9);
  }
}

TEST(MinCostAssignment, ForbiddenPairsAndRectangularProblems) {
  const double no = 1e9;
  // Greedy would give row 0 column 0 and leave row 1 unmatched.
  const std::vector<std::vector<double>> cost = {{0.1, 0.2, no}, {0.15, no, no}};
  EXPECT_EQ(MinCostAssignment(cost, no), (std::vector<int>{1, 0}));
  EXPECT_EQ(MinCostAssignment({{no, no}}, no), (std::vector<int>{-1}));
  EXPECT_TRUE(MinCostAssignment({}, no).empty());
}

GroundTruth Truth() {
  GroundTruth truth;
  truth.trajectory = {{0, 0, 0}, {0.2, 0, 0}, {0.4, 0, 0.1}};
  GroundTruthObject box;
  box.id = 0;
  box.class_name = "green box";
  box.base_world = {1, 1, 0};
  box.diameter_m = 0.68;
  box.height_m = 0.57;
  GroundTruthObject ball = box;
  ball.id = 1;
  ball.class_name = "pink ball";
  ball.base_world = {-1, 0.5, 0};
  ball.diameter_m = ball.height_m = 0.2;
  GroundTruthObject bench = box;  // a distractor: never counted
  bench.id = 2;
  bench.class_name = "";
  bench.base_world = {3, 3, 0};
  truth.objects = {box, ball, bench};
  return truth;
}

TEST(EvaluateMap, CountsFoundSpuriousAndErrors) {
  OMap map;
  map.trajectory = {{0, 0, 0}, {0.2, 0.1, 0}, {0.4, 0, 0.1}};
  OMapObject box;
  box.id = 5;
  box.class_name = "green box";
  box.base_world = {1.1, 1, 0};
  box.diameter_m = 0.6;
  box.height_m = 0.6;
  box.existence_probability = 0.9;
  OMapObject wrong_class = box;  // on the ball, but called a box
  wrong_class.id = 6;
  wrong_class.base_world = {-1, 0.5, 0.3};
  wrong_class.diameter_m = wrong_class.height_m = 0.25;
  OMapObject ghost = box;  // far from everything: spurious
  ghost.id = 7;
  ghost.base_world = {5, -5, 0};
  OMapObject unlikely = ghost;  // below the threshold: not in the map
  unlikely.id = 8;
  unlikely.existence_probability = 0.3;
  map.objects = {box, wrong_class, ghost, unlikely};
  const std::vector<Pose2> odometry = {{0, 0, 0}, {0.3, 0, 0}, {0.5, 0.2, 0.1}};

  const MapMetrics m = EvaluateMap(map, odometry, Truth());
  EXPECT_EQ(m.true_objects_total, 2);
  EXPECT_EQ(m.true_objects_found, 2);
  EXPECT_EQ(m.spurious_objects, 1);
  EXPECT_DOUBLE_EQ(m.class_accuracy, 0.5);
  EXPECT_NEAR(m.object_position_error_median_m, 0.5 * (0.1 + 0.3), 1e-12);
  EXPECT_NEAR(m.diameter_error_mean_m, 0.5 * (0.08 + 0.05), 1e-12);
  EXPECT_NEAR(m.height_error_mean_m, 0.5 * (0.03 + 0.05), 1e-12);
  EXPECT_NEAR(m.estimate.ate_rmse_m, std::sqrt(0.01 / 3), 1e-12);
  EXPECT_NEAR(m.odometry.ate_rmse_m, std::sqrt((0.01 + 0.01 + 0.04) / 3), 1e-12);
  EXPECT_GT(m.estimate.rpe_translation_rmse_m, 0.0);
  // eval.json has the keys its readers rely on.
  const std::string json = m.Json();
  for (const char* key :
       {"ate_rmse_m", "odometry_ate_rmse_m", "object_position_error_median_m",
        "object_horizontal_error_median_m", "diameter_error_mean_m", "height_error_mean_m",
        "class_accuracy", "true_objects_found", "true_objects_total", "spurious_objects"})
    EXPECT_NE(json.find(std::string("\"") + key + "\""), std::string::npos) << key;

  // The ball's match is 0.3 m off in height only: 3D and horizontal errors differ.
  EXPECT_EQ(m.class_correct, 1);
  EXPECT_NEAR(m.object_position_error_max_m, 0.3, 1e-12);
  EXPECT_NEAR(m.object_horizontal_error_median_m, 0.5 * (0.1 + 0.0), 1e-12);
  EXPECT_NEAR(m.object_horizontal_error_max_m, 0.1, 1e-12);
  // The printed table names each of the two (what `oslam run` and `oslam eval` print).
  EXPECT_NE(m.Table().find("median 0.200 m 3D, 0.050 m horizontal"), std::string::npos)
      << m.Table();
  ASSERT_EQ(m.matches.size(), 2u);
  EXPECT_EQ(m.matches[1].map_id, 6);
  EXPECT_NEAR(m.matches[1].position_error_m, 0.3, 1e-12);
  EXPECT_NEAR(m.matches[1].horizontal_error_m, 0.0, 1e-12);
  EXPECT_TRUE(m.missed_classes.empty());

  MapMetricsOptions strict;
  strict.match_gate_m = 0.05;  // the box is 0.1 m off: no longer a match
  const MapMetrics gated = EvaluateMap(map, odometry, Truth(), strict);
  EXPECT_EQ(gated.true_objects_found, 1);
  EXPECT_EQ(gated.spurious_objects, 2);
  EXPECT_EQ(gated.missed_classes, (std::vector<std::string>{"green box"}));
}

// Closest pairs first would give the middle map object to the left true
// object and leave the right one unmatched; the assignment finds both.
TEST(EvaluateMap, MatchesAsManyTrueObjectsAsTheGateAllows) {
  GroundTruth truth = Truth();
  truth.objects.resize(2);
  truth.objects[0].base_world = {0, 0, 0};
  truth.objects[1].base_world = {0.8, 0, 0};
  OMap map;
  map.trajectory = truth.trajectory;
  OMapObject middle;
  middle.id = 0;
  middle.class_name = "green box";
  middle.base_world = {0.4, 0, 0};
  OMapObject left = middle;
  left.id = 1;
  left.base_world = {-0.45, 0, 0};
  map.objects = {middle, left};
  const MapMetrics m = EvaluateMap(map, truth.trajectory, truth);
  EXPECT_EQ(m.true_objects_found, 2);
  EXPECT_EQ(m.spurious_objects, 0);
  ASSERT_EQ(m.matches.size(), 2u);
  EXPECT_EQ(m.matches[0].map_id, 1);
  EXPECT_EQ(m.matches[1].map_id, 0);
  EXPECT_NEAR(m.object_horizontal_error_median_m, 0.425, 1e-12);
}

// Known association: the map keeps the true ids, and a map object is
// compared with the true object of its id however far off it is.
TEST(EvaluateMap, ByIdMatchesTheTrueObjectOfTheSameId) {
  OMap map;
  map.trajectory = Truth().trajectory;
  OMapObject box;
  box.id = 0;
  box.class_name = "green box";
  box.base_world = {1, 3, 0};  // 2 m off: beyond any gate
  box.diameter_m = 0.7;
  box.height_m = 0.5;
  OMapObject bench = box;  // the distractor's id: no true object to find
  bench.id = 2;
  OMapObject ball = box;  // below the existence threshold: not in the map
  ball.id = 1;
  ball.existence_probability = 0.2;
  map.objects = {box, bench, ball};
  MapMetricsOptions by_id;
  by_id.matching = ObjectMatching::kById;
  const MapMetrics m = EvaluateMap(map, map.trajectory, Truth(), by_id);
  EXPECT_EQ(m.true_objects_total, 2);
  EXPECT_EQ(m.true_objects_found, 1);
  EXPECT_EQ(m.spurious_objects, 1);
  EXPECT_EQ(m.missed_classes, (std::vector<std::string>{"pink ball"}));
  EXPECT_NEAR(m.object_position_error_median_m, 2.0, 1e-12);
  EXPECT_NEAR(m.object_position_error_max_m, 2.0, 1e-12);
  EXPECT_NEAR(m.diameter_error_mean_m, 0.02, 1e-12);
  EXPECT_NEAR(m.height_error_mean_m, 0.07, 1e-12);
  EXPECT_EQ(m.estimate.ate_rmse_m, 0.0);
  // Nearest matching with the default gate finds nothing there.
  EXPECT_EQ(EvaluateMap(map, map.trajectory, Truth()).true_objects_found, 0);
}

TEST(EvaluateMap, MismatchedTrajectoryLengthIsAnError) {
  OMap map;
  map.trajectory = {{0, 0, 0}};
  EXPECT_THROW(EvaluateMap(map, {{0, 0, 0}}, Truth()), Error);
}

}  // namespace
}  // namespace oslam
