// O-Map fusion of samples (docs/method.md §7.3) and the identity merging beyond the
// thesis: identities that describe one physical object in
// different samples become one map object; distinct objects stay apart.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/LU>

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
          std::find(o.tracks.begin(), o.tracks.end(), e->state.blocks[j].front()) != o.tracks.end())
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

// The solver's sizes are unconstrained: a sliver of an object can come out
// a few cm below zero. The O-Map never carries a negative size (its reader
// would reject the file the run just wrote).
TEST(OMapFusionTest, ASizeBelowZeroIsReportedAsZero) {
  const EvaluationPtr sample = Sample({{{0}, {1.0, 0, 0}}});
  auto solution = std::make_shared<GeometricSlamResult>(*sample->solution);
  solution->objects[0].geometry.diameter_m = -0.04;
  solution->objects[0].geometry.height_m = -0.01;
  auto sliver = std::make_shared<StateEvaluation>(*sample);
  sliver->solution = solution;
  const FusionResult r = FuseSamples({sliver}, Classes(), {3}, NoSpurious(false));
  ASSERT_EQ(r.map.objects.size(), 1u);
  EXPECT_EQ(r.map.objects[0].diameter_m, 0.0);
  EXPECT_EQ(r.map.objects[0].height_m, 0.0);
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
  FusionOptions thesis_xi;  // P(xi) of the location uncertainty alone
  thesis_xi.class_geometry_evidence = false;
  const FusionResult r = FuseSamples(AlternatingSamples(10), Classes(), {3, 3, 3, 2}, thesis_xi);
  ASSERT_FALSE(r.map.objects.empty());
  EXPECT_EQ(r.identities[0].num_samples, 10);
  EXPECT_GT(r.map.objects[0].existence_probability, 0.97);
  EXPECT_LE(r.map.objects[0].existence_probability, 1.0 / (1.0 + std::exp(-4.0)) + 1e-9);
}

using Matrix5d = Eigen::Matrix<double, 5, 5>;
using Vector5d = Eigen::Matrix<double, 5, 1>;

// The green box of the size priors (thesis Table 6.4), with the thesis'
// location prior.
ClassPrior GreenBox() {
  ClassPrior prior;
  prior.name = "green box";
  prior.size_mean_m = {0.6, 0.6};
  prior.size_std_m = {0.3, 0.15};
  return prior;
}

// The posterior (covariance, mean) of theta = (l, g) from a prior-free
// Gaussian likelihood N(theta_data, information^-1) and the class prior.
std::pair<Matrix5d, Vector5d> Posterior(const ClassPrior& prior, const Vector5d& information,
                                        const Vector5d& theta_data) {
  Vector5d mu, std;
  mu << prior.location_mean_m, prior.size_mean_m;
  std << prior.location_std_m, prior.size_std_m;
  const Vector5d prior_information = std.array().square().inverse();
  const Vector5d total = information + prior_information;
  const Matrix5d covariance = total.cwiseInverse().asDiagonal();
  const Vector5d mean =
      covariance * (information.cwiseProduct(theta_data) + prior_information.cwiseProduct(mu));
  return {covariance, mean};
}

double LogNormal(double x, double mean, double std) {
  return -std::log(std) - 0.5 * std::pow((x - mean) / std, 2);
}

// With precise detections the Bayes factor is the ratio of the class's and
// the look-alike's prior densities at the measured geometry (closed form).
TEST(ClassGeometryEvidence, PreciseGeometryGivesTheRatioOfPriorDensities) {
  const ClassPrior prior = GreenBox();
  const FusionOptions options;
  for (const auto& [d, h] : {std::pair{0.55, 0.6}, {0.05, 0.1}, {1.2, 0.3}}) {
    SCOPED_TRACE(::testing::Message() << "d " << d << " h " << h);
    Vector5d theta;
    theta << 1.0, 2.0, 0.0, d, h;
    const auto [covariance, mean] = Posterior(prior, Vector5d::Constant(1e8), theta);
    const double expected =
        LogNormal(d, 0.6, 0.3) - LogNormal(d, 0.6, options.lookalike_size_std_m) +
        LogNormal(h, 0.6, 0.15) - LogNormal(h, 0.6, options.lookalike_size_std_m);
    EXPECT_NEAR(ClassGeometryLogBayesFactor(covariance, mean, prior, options), expected, 1e-3);
  }
  // The look-alike: 5 cm wide and 10 cm tall is no green box.
  Vector5d leg;
  leg << 1.0, 2.0, 0.0, 0.05, 0.1;
  const auto [covariance, mean] = Posterior(prior, Vector5d::Constant(1e4), leg);
  EXPECT_LT(ClassGeometryLogBayesFactor(covariance, mean, prior, options), -3.0);
  // A support prior (the base on the floor within 2 cm) makes a base 0.65 m
  // above the floor decisive evidence against the class.
  ClassPrior supported = prior;
  supported.location_std_m.z() = 0.02;
  Vector5d floating;
  floating << 1.0, 2.0, 0.65, 0.6, 0.6;
  const auto [c2, m2] = Posterior(supported, Vector5d::Constant(1e4), floating);
  EXPECT_LT(ClassGeometryLogBayesFactor(c2, m2, supported, options), -100.0);
}

// Detections that say nothing about the size (or base height) leave the
// odds as they are.
TEST(ClassGeometryEvidence, UninformativeGeometryIsNoEvidence) {
  const ClassPrior prior = GreenBox();
  Vector5d information;
  information << 1e4, 1e4, 0.0, 0.0, 0.0;
  Vector5d theta;
  theta << 1.0, 2.0, 0.0, 0.6, 0.6;
  const auto [covariance, mean] = Posterior(prior, information, theta);
  EXPECT_NEAR(ClassGeometryLogBayesFactor(covariance, mean, prior, FusionOptions{}), 0.0, 1e-6);
}

// Spurious, look-alike or of the class: P(xi) times P(class | consistent),
// the Bayes factor weighed against the look-alike's prior.
TEST(ClassGeometryEvidence, ExistenceWeightIsConsistencyTimesTheClassAgainstALookAlike) {
  const ClassPrior prior = GreenBox();
  Vector5d theta;
  theta << 1.0, 2.0, 0.0, 0.3, 0.45;
  const auto [covariance, mean] = Posterior(prior, Vector5d::Constant(100.0), theta);
  FusionOptions options;
  const double p = NonSpuriousProbability(covariance, prior, options);
  ASSERT_GT(p, 0.5);
  ASSERT_LT(p, 0.99);
  const double log_bf = ClassGeometryLogBayesFactor(covariance, mean, prior, options);
  EXPECT_NEAR(ExistenceWeight(covariance, mean, prior, options), p / (1 + std::exp(-log_bf)),
              1e-12);
  options.lookalike_prior = 0.2;  // prior odds 4 : 1 for the class
  EXPECT_NEAR(ExistenceWeight(covariance, mean, prior, options),
              p / (1 + std::exp(-log_bf - std::log(4.0))), 1e-12);
  // A well-located look-alike: p near 1 does not outweigh the geometry.
  Vector5d wide;
  wide << 1.0, 2.0, 0.0, 1.8, 0.6;
  const auto [c2, m2] = Posterior(prior, Vector5d::Constant(1e6), wide);
  options.lookalike_prior = 0.5;
  EXPECT_LT(ExistenceWeight(c2, m2, prior, options), 0.5);
  options.lookalike_prior = 1.0;
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(why.find("look-alike"), std::string::npos) << why;
  options.lookalike_prior = 0.5;
  options.class_geometry_evidence = false;
  EXPECT_EQ(ExistenceWeight(covariance, mean, prior, options), p);
  options.spurious_model = false;
  EXPECT_EQ(ExistenceWeight(covariance, mean, prior, options), 1.0);
  options = {};
  options.lookalike_size_std_m = 0;
  EXPECT_FALSE(options.Validate(&why));
}

// An object seen from one place only (the robot turning on the spot): the
// detections fix its bearing, its base height and its apparent size, i.e.
// diameter / range and height / range, but not the range. Without any class
// prior (4.43) the range is open and P(xi) = 0; given the class, the size
// prior locates it: range variance x^2 / ((d/sigma_d)^2 + (h/sigma_h)^2).
TEST(ExistenceGivenClass, AnObjectSeenFromOnePlaceIsLocatedByItsApparentSize) {
  ClassPrior bottle;  // thesis Table 6.4
  bottle.name = "red bottle";
  bottle.size_mean_m = {0.1, 0.3};
  bottle.size_std_m = {0.05, 0.1};
  for (const double range : {1.0, 2.0}) {
    SCOPED_TRACE(::testing::Message() << "range " << range);
    Vector5d theta;  // seen along +x from the origin, at the class's mean size
    theta << range, 0.0, 0.0, 0.1, 0.3;
    // Precise measurements of y, z, d - (d/x) x and h - (h/x) x.
    std::vector<Vector5d> rows(4, Vector5d::Zero());
    rows[0] << 0, 1, 0, 0, 0;
    rows[1] << 0, 0, 1, 0, 0;
    rows[2] << -0.1 / range, 0, 0, 1, 0;
    rows[3] << -0.3 / range, 0, 0, 0, 1;
    Matrix5d information = Matrix5d::Zero();
    for (const Vector5d& a : rows) information += 1e8 * a * a.transpose();
    Vector5d prior_std;
    prior_std << bottle.location_std_m, bottle.size_std_m;
    Matrix5d posterior_information = information;
    posterior_information.diagonal() += prior_std.array().square().inverse().matrix();
    const Matrix5d covariance = posterior_information.inverse();
    const Vector5d mean = theta;  // the class means: no prior pull on the size
    EXPECT_TRUE(std::isinf(PriorFreeLocationVariance(covariance, bottle)));
    const double expected = range * range / (std::pow(0.1 / 0.05, 2) + std::pow(0.3 / 0.1, 2));
    EXPECT_NEAR(ClassConditionedLocationVariance(covariance, bottle), expected, 1e-3 * expected);
    FusionOptions thesis;
    thesis.existence_given_class = false;
    EXPECT_EQ(ExistenceWeight(covariance, mean, bottle, thesis), 0.0);
    FusionOptions given_class;
    given_class.existence_given_class = true;
    const double p = MirroredSigmoid(ClassConditionedLocationVariance(covariance, bottle),
                                     given_class.spurious_t0_m2, given_class.spurious_tau_m2);
    const double log_bf = ClassGeometryLogBayesFactor(covariance, mean, bottle, given_class);
    EXPECT_NEAR(ExistenceWeight(covariance, mean, bottle, given_class), p / (1 + std::exp(-log_bf)),
                1e-12);
  }
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
