// O-Map fusion of samples (docs/method.md §7.3) and the identity merging beyond the
// thesis: identities that describe one physical object in
// different samples become one map object; distinct objects stay apart.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "association/omap_fusion.h"

namespace oslam {
namespace {

struct TestObject {
  std::vector<int> tracks;
  Eigen::Vector3d base;
  int class_index = 0;
};

EvaluationPtr Sample(const std::vector<TestObject>& objects) {
  auto e = std::make_shared<StateEvaluation>();
  auto solution = std::make_shared<GeometricSlamResult>();
  solution->trajectory = {{0, 0, 0}, {1, 0, 0.1}};
  for (const TestObject& o : objects) {
    e->state.blocks.push_back(o.tracks);
    e->state.classes.push_back(o.class_index);
  }
  e->state.Canonicalize();
  for (size_t j = 0; j < e->state.blocks.size(); ++j) {
    const TestObject* source = nullptr;
    for (const TestObject& o : objects)
      if (o.tracks.front() == e->state.blocks[j].front() ||
          std::find(o.tracks.begin(), o.tracks.end(), e->state.blocks[j].front()) !=
              o.tracks.end())
        source = &o;
    MappedObject m;
    m.id = e->state.blocks[j].front();
    m.class_index = source->class_index;
    m.geometry.base_world = source->base;
    m.geometry.diameter_m = 0.3;
    m.geometry.height_m = 0.5;
    m.covariance = 1e-4 * Eigen::Matrix<double, 5, 5>::Identity();
    solution->objects.push_back(m);
  }
  std::sort(solution->objects.begin(), solution->objects.end(),
            [](const MappedObject& a, const MappedObject& b) { return a.id < b.id; });
  e->valid = true;
  e->solution = solution;
  return e;
}

std::vector<ClassPrior> Classes() {
  ClassPrior a, b;
  a.name = "box";
  b.name = "ball";
  return {a, b};
}

FusionOptions NoSpurious(bool merge) {
  FusionOptions options;
  options.spurious_model = false;
  options.merge_identities = merge;
  return options;
}

// Object O (tracks 0, 1) at (1, 0, 0) is joined by track 3 in every other
// sample; otherwise track 3 is a far-away object of its own. Object P
// (track 2) is 0.3 m from O and present in every sample.
std::vector<EvaluationPtr> AlternatingSamples(int n) {
  std::vector<EvaluationPtr> samples;
  for (int i = 0; i < n; ++i) {
    if (i % 2 == 0)
      samples.push_back(Sample({{{0, 1}, {1.0, 0, 0}}, {{2}, {1.3, 0, 0}}, {{3}, {5, 5, 0}}}));
    else
      samples.push_back(Sample({{{0, 1, 3}, {1.04, 0, 0}}, {{2}, {1.3, 0, 0}}}));
  }
  return samples;
}

TEST(OMapFusionTest, ThesisFusionKeepsOneObjectPerIdentity) {
  const FusionResult r =
      FuseSamples(AlternatingSamples(10), Classes(), {3, 3, 3, 2}, NoSpurious(false));
  ASSERT_EQ(r.map.objects.size(), 4u);  // {2}, {0,1}, {0,1,3}, {3}
  EXPECT_DOUBLE_EQ(r.map.objects[0].existence_probability, 1.0);
  for (size_t i = 1; i < 4; ++i) EXPECT_DOUBLE_EQ(r.map.objects[i].existence_probability, 0.5);
  ASSERT_EQ(r.map.trajectory.size(), 2u);
  EXPECT_NEAR(r.map.trajectory[1].theta, 0.1, 1e-12);
}

TEST(OMapFusionTest, AlternatingIdentitiesOfOneObjectBecomeOne) {
  const FusionResult r =
      FuseSamples(AlternatingSamples(10), Classes(), {3, 3, 3, 2}, NoSpurious(true));
  ASSERT_EQ(r.map.objects.size(), 3u);
  // O: both identities, present in every sample; geometry weighted by samples.
  ASSERT_EQ(r.identities[0].tracks, (std::vector<int>{0, 1, 3}));
  ASSERT_EQ(r.identities[0].members.size(), 2u);
  EXPECT_EQ(r.identities[0].num_samples, 10);
  EXPECT_DOUBLE_EQ(r.map.objects[0].existence_probability, 1.0);
  EXPECT_NEAR(r.map.objects[0].base_world.x(), 1.02, 1e-12);
  EXPECT_EQ(r.map.objects[0].num_detections, 8);
  // The position spread of the two identities enters the covariance.
  EXPECT_NEAR(r.map.objects[0].covariance(0, 0), 1e-4 + 0.02 * 0.02, 1e-12);
  // P, 0.3 m away, co-occurs with O in every sample: a distinct object.
  EXPECT_EQ(r.identities[1].tracks, (std::vector<int>{2}));
  EXPECT_DOUBLE_EQ(r.map.objects[1].existence_probability, 1.0);
  // The far-away track 3 alone: its own identity, half the samples.
  EXPECT_EQ(r.identities[2].tracks, (std::vector<int>{3}));
  EXPECT_DOUBLE_EQ(r.map.objects[2].existence_probability, 0.5);
}

TEST(OMapFusionTest, DistinctNearbyObjectsAreNotJoinedThroughARareMergedIdentity) {
  // A (track 0) and B (track 1), 0.3 m apart, are separate in 9 of 10
  // samples and merged into one object in the tenth.
  std::vector<EvaluationPtr> samples;
  for (int i = 0; i < 10; ++i) {
    if (i == 4)
      samples.push_back(Sample({{{0, 1}, {0.15, 0, 0}}}));
    else
      samples.push_back(Sample({{{0}, {0, 0, 0}}, {{1}, {0.3, 0, 0}}}));
  }
  const FusionResult r = FuseSamples(samples, Classes(), {4, 4}, NoSpurious(true));
  ASSERT_EQ(r.map.objects.size(), 2u);
  int above = 0;
  for (const OMapObject& o : r.map.objects) above += o.existence_probability > 0.5;
  EXPECT_EQ(above, 2);
  EXPECT_DOUBLE_EQ(r.map.objects[0].existence_probability, 1.0);  // joined the rare {0, 1}
  EXPECT_DOUBLE_EQ(r.map.objects[1].existence_probability, 0.9);
}

TEST(OMapFusionTest, IdentityMergingIsClassAware) {
  // One place, two identities of different classes that never co-occur.
  std::vector<EvaluationPtr> samples;
  for (int i = 0; i < 4; ++i)
    samples.push_back(i % 2 ? Sample({{{0, 1}, {0, 0, 0}, 0}, {{2}, {3, 0, 0}, 0}})
                            : Sample({{{0, 1, 2}, {0.1, 0, 0}, 1}}));
  FusionOptions options = NoSpurious(true);
  EXPECT_EQ(FuseSamples(samples, Classes(), {3, 3, 3}, options).map.objects.size(), 2u);
  options.identity_class_mismatch_penalty = std::numeric_limits<double>::infinity();
  EXPECT_EQ(FuseSamples(samples, Classes(), {3, 3, 3}, options).map.objects.size(), 3u);
  options.identity_class_mismatch_penalty = 3.0;
  options.identity_merge_distance_m = 0.1;  // 0.1 * sqrt(3) > 0.1: apart
  EXPECT_EQ(FuseSamples(samples, Classes(), {3, 3, 3}, options).map.objects.size(), 3u);
}

TEST(OMapFusionTest, MergedExistenceCountsEachSampleOnceWithItsLargestXi) {
  // With the spurious model, a sample holding the object contributes the
  // P(xi) of the member it holds: pi stays <= S(0) ~ 0.982.
  const FusionResult r =
      FuseSamples(AlternatingSamples(10), Classes(), {3, 3, 3, 2}, FusionOptions{});
  ASSERT_FALSE(r.map.objects.empty());
  EXPECT_EQ(r.identities[0].num_samples, 10);
  EXPECT_GT(r.map.objects[0].existence_probability, 0.97);
  EXPECT_LE(r.map.objects[0].existence_probability, 1.0 / (1.0 + std::exp(-4.0)) + 1e-9);
}

TEST(OMapFusionTest, InvalidIdentityMergingOptionsAreRefused) {
  FusionOptions options;
  options.identity_max_cooccurrence = 1.5;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(why.find("co-occurrence"), std::string::npos);
}

}  // namespace
}  // namespace oslam
