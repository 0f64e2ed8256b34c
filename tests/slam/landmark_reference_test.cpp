// The references an association found with the ids hidden is scored
// against: on a simulated drive whose ids are corrupted in the two ways real
// files are (one landmark given two ids; sightings given a wrong id), the
// duplicates are joined back and the wrong sightings left out, and nothing
// else is touched.
#include "slam/landmark_reference.h"

#include <algorithm>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "core/error.h"
#include "slam/landmark_simulation.h"

namespace oslam {
namespace {

LandmarkWorld SmallCity() {
  LandmarkWorldOptions options;
  options.num_poses = 600;
  options.num_landmarks = 80;
  options.clutter_per_scan = 0;
  options.seed = 5;
  return SimulateLandmarkWorld(options);
}

// The landmark with the most sightings.
int MostSeen(const std::vector<int>& ids) {
  std::map<int, int> count;
  for (int id : ids) ++count[id];
  return std::max_element(count.begin(), count.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; })
      ->first;
}

TEST(LandmarkReferenceTest, JoinsALandmarkTheFileGaveTwoIds) {
  const LandmarkWorld world = SmallCity();
  std::vector<int> ids = world.true_association;
  const int tree = MostSeen(ids);
  const int duplicate = 1000;
  // Its sightings from the second half of its scans get a second id.
  std::vector<int> its;
  for (size_t k = 0; k < ids.size(); ++k)
    if (ids[k] == tree) its.push_back(static_cast<int>(k));
  ASSERT_GE(its.size(), 10u);
  for (size_t i = its.size() / 2; i < its.size(); ++i) ids[its[i]] = duplicate;
  LandmarkSlamOptions options;
  options.compute_landmark_covariances = false;
  const LandmarkSlamResult solved = LandmarkSlam(options).Solve(world.data, ids);
  int joined = 0;
  const std::vector<int> fixed = JoinDuplicateLandmarks(world.data, ids, solved, 0.25, &joined);
  EXPECT_EQ(joined, 1);
  EXPECT_EQ(fixed, world.true_association);
}

TEST(LandmarkReferenceTest, LeavesOutSightingsGivenAWrongIdAndNothingElse) {
  const LandmarkWorld world = SmallCity();
  std::vector<int> ids = world.true_association;
  // Three sightings tied to a landmark at least 10 m from the true one,
  // one seen often enough to be placed by its own sightings.
  std::map<int, int> seen;
  for (int id : ids) ++seen[id];
  std::set<int> wrong;
  for (size_t k = 0; k < ids.size() && wrong.size() < 3; k += 97) {
    const Eigen::Vector2d at = world.true_landmarks[ids[k]];
    for (size_t l = 0; l < world.true_landmarks.size(); ++l)
      if (seen[static_cast<int>(l)] >= 5 && (world.true_landmarks[l] - at).norm() > 10) {
        ids[k] = static_cast<int>(l);
        wrong.insert(static_cast<int>(k));
        break;
      }
  }
  ASSERT_EQ(wrong.size(), 3u);
  LandmarkSlamOptions options;
  options.compute_landmark_covariances = false;
  LandmarkSlamResult clean;
  int removed = 0;
  const std::vector<int> kept =
      LeaveOutOutlierSightings(world.data, ids, options, 25, &clean, &removed);
  EXPECT_EQ(removed, 3);
  for (size_t k = 0; k < ids.size(); ++k)
    EXPECT_EQ(kept[k], wrong.count(static_cast<int>(k)) ? -1 : ids[k]) << "sighting " << k;
  // Its solve is that of the true association without those sightings.
  std::vector<int> without = world.true_association;
  for (int k : wrong) without[k] = -1;
  const LandmarkSlamResult expected = LandmarkSlam(options).Solve(world.data, without);
  ASSERT_EQ(clean.trajectory.size(), expected.trajectory.size());
  for (size_t i = 0; i < clean.trajectory.size(); i += 50) {
    EXPECT_NEAR(clean.trajectory[i].x, expected.trajectory[i].x, 1e-3);
    EXPECT_NEAR(clean.trajectory[i].y, expected.trajectory[i].y, 1e-3);
  }
}

TEST(LandmarkReferenceTest, RejectsMismatchedIdsAndAZeroGate) {
  const LandmarkWorld world = SmallCity();
  LandmarkSlamResult solved;
  EXPECT_THROW(JoinDuplicateLandmarks(world.data, {0, 1}, solved, 0.25), Error);
  EXPECT_THROW(LeaveOutOutlierSightings(world.data, world.true_association, {}, 0), Error);
}

}  // namespace
}  // namespace oslam
