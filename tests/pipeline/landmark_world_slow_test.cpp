// The landmark association on simulated city drives long enough for loops
// of a kilometre: a re-entry whose correction must be spread along the whole
// loop (docs/method.md §16.2, the joint merges' loop anchor), and one of a
// few trees only (the screen of small re-entries).
#include <cstdio>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "association/association_metrics.h"
#include "pipeline/landmark_association.h"
#include "slam/landmark_noise.h"
#include "slam/landmark_simulation.h"
#include "slam/landmark_slam.h"

namespace oslam {
namespace {

// The first 2,500 poses of the 5,000-pose world of docs/benchmarks.md: at
// 2,360 poses the robot re-enters streets last seen 1.3 km before, with a
// 0.32 rad heading correction. RANSAC pairs every re-seen tree rightly, but
// the correction spread over the last 170 or 340 m only ends below the state
// before; spread along the whole loop it closes the loop. Under the default
// density prior it closes without the loop anchor too (P 0.9994 R 0.9991
// both), so this test checks the defaults only.
TEST(LandmarkWorldSlowTest, AKilometreLoopCloses) {
  LandmarkWorldOptions world_options;
  world_options.num_poses = 5000;
  world_options.num_landmarks = 800;
  world_options.blocks = 8;
  const LandmarkWorld world = SimulateLandmarkWorld(world_options);
  const LandmarkDataset data = PosePrefix(world.data, 2500);
  // The file's ids: the true landmarks, every clutter sighting one of its own.
  std::vector<int> truth;
  for (const LandmarkSighting& z : data.sightings) truth.push_back(z.landmark);
  UnknownAssociationOptions without;
  without.joint_loop_anchor = false;
  const UnknownAssociationResult a = SolveUnknownAssociation(data, without);
  const UnknownAssociationResult b = SolveUnknownAssociation(data, {});
  const PairwiseAgreement pa = ComparePairwise(a.association, truth);
  const PairwiseAgreement pb = ComparePairwise(b.association, truth);
  std::printf("without the loop anchor: P %.4f R %.4f, %zu landmarks; with: P %.4f R %.4f, %zu\n",
              pa.precision, pa.recall, a.solution.landmarks.size(), pb.precision, pb.recall,
              b.solution.landmarks.size());
  // Measured: P 0.9994 R 0.9991 with and without, 474 landmarks (the
  // file's ids: 475, clutter sightings one each).
  EXPECT_GT(pa.recall, 0.99);
  EXPECT_GT(pb.recall, 0.99);
  EXPECT_GT(pb.precision, 0.99);
  const std::set<int> file_landmarks(truth.begin(), truth.end());
  EXPECT_NEAR(static_cast<double>(b.solution.landmarks.size()),
              static_cast<double>(file_landmarks.size()), 0.02 * file_landmarks.size());
  EXPECT_GE(b.log_target, a.log_target - 1e-3);
}

// The search on the first `num_poses` poses of a simulated world, without
// one feature (`without`) and with the defaults, against the file's ids and
// the true trajectory; the file's association solved under the defaults'
// own model (noise and prior).
struct Ablation {
  PairwiseAgreement without, with;  // against the file's ids
  double ate_without = 0, ate_with = 0, ate_file = 0;
  double without_from_file_m = 0;  // the search's trajectory without, from the file's solve
  double log_target_without = 0, log_target_with = 0;
};

Ablation RunAblation(const LandmarkWorldOptions& world_options, int num_poses,
                     const UnknownAssociationOptions& without) {
  const LandmarkWorld world = SimulateLandmarkWorld(world_options);
  const LandmarkDataset data = PosePrefix(world.data, num_poses);
  const std::vector<Pose2> truth(world.true_trajectory.begin(),
                                 world.true_trajectory.begin() + num_poses);
  std::vector<int> ids;
  for (const LandmarkSighting& z : data.sightings) ids.push_back(z.landmark);
  const UnknownAssociationResult a = SolveUnknownAssociation(data, without);
  const UnknownAssociationResult b = SolveUnknownAssociation(data, {});
  const LandmarkSlamResult file =
      LandmarkSlam(b.slam_options).Solve(WithNoiseScales(data, b.noise_scales), ids);
  Ablation result;
  result.without = ComparePairwise(a.association, ids);
  result.with = ComparePairwise(b.association, ids);
  result.ate_without = TrajectoryRmse(a.solution.trajectory, truth);
  result.ate_with = TrajectoryRmse(b.solution.trajectory, truth);
  result.ate_file = TrajectoryRmse(file.trajectory, truth);
  result.without_from_file_m = TrajectoryRmse(a.solution.trajectory, file.trajectory);
  result.log_target_without = a.log_target;
  result.log_target_with = b.log_target;
  std::printf(
      "without: P %.4f R %.4f, ATE %.2f m (%.2f m from the file's association's solve); with: P "
      "%.4f R %.4f, ATE %.2f m; the file's association %.2f m\n",
      result.without.precision, result.without.recall, result.ate_without,
      result.without_from_file_m, result.with.precision, result.with.recall, result.ate_with,
      result.ate_file);
  return result;
}

// The first 3,000 poses of the 10,000-pose world of docs/benchmarks.md: a
// few trees seen again after drift, too few for the RANSAC floors, and each
// single merge with rivals of nearly equal gain; judged together by their
// joint compatibility (the screen of small re-entries) they close the loop.
// (The first 1,500 poses need no screen: 2.33 m from the truth either way.)
TEST(LandmarkWorldSlowTest, AFewTreesSeenAgainAfterDriftAreMergedTogether) {
  LandmarkWorldOptions world_options;
  world_options.num_poses = 10000;
  world_options.num_landmarks = 1200;
  world_options.blocks = 10;
  UnknownAssociationOptions without;
  without.joint_screen_candidates = 0;
  const Ablation r = RunAblation(world_options, 3000, without);
  // Measured: without the screen P 0.9984 R 0.9937, ATE 9.25 m (9.3 m from
  // the file's association's solve); with it the file's association, 1.35 m.
  EXPECT_LT(r.without.recall, 0.999);
  EXPECT_GT(r.without_from_file_m, 2.0);
  EXPECT_LT(r.ate_with, 1.2 * r.ate_file);
  EXPECT_GT(r.with.precision, 0.999);
  EXPECT_GT(r.with.recall, 0.999);
  EXPECT_GT(r.log_target_with, r.log_target_without);
}

// The 20,000-pose world's first re-entry (poses 935-970 onto trees seen at
// 692-730): a window's batch of merges holds one pair of two different trees,
// which sinks the batch's re-solve; the single best merge by gain is that
// wrong pair, and the map stays folded from there. Undoing the batch's
// misfit merges (targeted_repair_rounds) keeps the right ones.
TEST(LandmarkWorldSlowTest, ABatchOfMergesKeepsItsRightPairsWhenOneIsWrong) {
  LandmarkWorldOptions world_options;
  world_options.num_poses = 20000;
  world_options.num_landmarks = 2000;
  world_options.blocks = 14;
  UnknownAssociationOptions unrepaired;
  unrepaired.targeted_repair_rounds = 0;
  const Ablation r = RunAblation(world_options, 1300, unrepaired);
  // Measured: unrepaired P 0.995 R 0.888, 5.26 m; repaired the true
  // association, 4.32 m (the file's association 4.36 m).
  EXPECT_LT(r.without.recall, 0.99);
  EXPECT_GT(r.with.precision, 0.999);
  EXPECT_GT(r.with.recall, 0.999);
  EXPECT_LT(r.ate_with, 1.05 * r.ate_file);
}

}  // namespace
}  // namespace oslam
