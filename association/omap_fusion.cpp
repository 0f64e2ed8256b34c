#include "association/omap_fusion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/error.h"

namespace oslam {
namespace {

using Matrix5d = Eigen::Matrix<double, 5, 5>;
using Vector5d = Eigen::Matrix<double, 5, 1>;

struct Accumulator {
  int count = 0;
  Vector5d mean_sum = Vector5d::Zero();
  Matrix5d second_sum = Matrix5d::Zero();  // sum of mean mean^T
  Matrix5d covariance_sum = Matrix5d::Zero();
  std::map<int, int> class_counts;
  // A panel's orientation: sum of (cos 2 yaw, sin 2 yaw) over the samples
  // that hold it as a panel (its period is pi), and their count.
  Eigen::Vector2d doubled_yaw_sum = Eigen::Vector2d::Zero();
  int yaw_count = 0;
  // (sample index, P(xi)) in sample order; one entry per sample (merged
  // identities keep the largest P(xi) of a sample).
  std::vector<std::pair<int, double>> presence;
  std::vector<std::pair<std::vector<int>, int>> members;  // identity, its samples

  Vector5d Mean() const { return mean_sum / count; }
  int Class() const {
    int best = -1, best_count = -1;
    for (const auto& [c, n] : class_counts)
      if (n > best_count) best = c, best_count = n;  // ties: the lower class index
    return best;
  }
};

// Samples in which both hold an identity.
int CoOccurrences(const Accumulator& a, const Accumulator& b) {
  int n = 0;
  auto i = a.presence.begin(), j = b.presence.begin();
  while (i != a.presence.end() && j != b.presence.end()) {
    if (i->first < j->first) {
      ++i;
    } else if (j->first < i->first) {
      ++j;
    } else {
      ++n, ++i, ++j;
    }
  }
  return n;
}

void MergeInto(Accumulator* a, Accumulator&& b) {
  a->count += b.count;
  a->mean_sum += b.mean_sum;
  a->second_sum += b.second_sum;
  a->covariance_sum += b.covariance_sum;
  a->doubled_yaw_sum += b.doubled_yaw_sum;
  a->yaw_count += b.yaw_count;
  for (const auto& [c, n] : b.class_counts) a->class_counts[c] += n;
  std::vector<std::pair<int, double>> presence;
  auto i = a->presence.begin(), j = b.presence.begin();
  while (i != a->presence.end() || j != b.presence.end()) {
    if (j == b.presence.end() || (i != a->presence.end() && i->first < j->first)) {
      presence.push_back(*i++);
    } else if (i == a->presence.end() || j->first < i->first) {
      presence.push_back(*j++);
    } else {
      presence.push_back({i->first, std::max(i->second, j->second)});
      ++i, ++j;
    }
  }
  a->presence = std::move(presence);
  for (auto& m : b.members) a->members.push_back(std::move(m));
}

// Squared class-aware distance between two identities' mean base points.
double IdentityDistance2(const Accumulator& a, const Accumulator& b, const FusionOptions& options) {
  double d2 = (a.Mean().head<3>() - b.Mean().head<3>()).squaredNorm();
  if (a.Class() != b.Class()) {
    if (std::isinf(options.identity_class_mismatch_penalty))
      return std::numeric_limits<double>::infinity();
    d2 *= options.identity_class_mismatch_penalty;
  }
  return d2;
}

bool Combinable(const Accumulator& a, const Accumulator& b, const FusionOptions& options) {
  const double limit = options.identity_merge_distance_m * options.identity_merge_distance_m;
  if (!(IdentityDistance2(a, b, options) < limit)) return false;
  const double rarer = static_cast<double>(std::min(a.presence.size(), b.presence.size()));
  return CoOccurrences(a, b) <= options.identity_max_cooccurrence * rarer;
}

// Greedy agglomeration (identity merging, docs/method.md §7.3): candidate pairs of identities,
// closest first; two groups are joined when their pooled means are still close and they rarely
// co-occur, so two distinct objects that are both present in most samples are never joined through
// a rare identity that spans both.
std::vector<Accumulator> CombineIdentities(std::vector<Accumulator> identities,
                                           const FusionOptions& options) {
  const size_t n = identities.size();
  std::vector<std::tuple<double, size_t, size_t>> pairs;
  const double limit = options.identity_merge_distance_m * options.identity_merge_distance_m;
  for (size_t a = 0; a < n; ++a)
    for (size_t b = a + 1; b < n; ++b) {
      const double d2 = IdentityDistance2(identities[a], identities[b], options);
      if (d2 < limit) pairs.emplace_back(d2, a, b);
    }
  std::sort(pairs.begin(), pairs.end());
  std::vector<size_t> root(n);
  for (size_t i = 0; i < n; ++i) root[i] = i;
  auto find = [&](size_t i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (const auto& [d2, a, b] : pairs) {
    const size_t ra = find(a), rb = find(b);
    if (ra == rb || !Combinable(identities[ra], identities[rb], options)) continue;
    MergeInto(&identities[ra], std::move(identities[rb]));
    root[rb] = ra;
  }
  std::vector<Accumulator> combined;
  for (size_t i = 0; i < n; ++i)
    if (find(i) == i) combined.push_back(std::move(identities[i]));
  return combined;
}

Vector5d Parameters(const MappedObject& object) {
  Vector5d v;
  v << object.geometry.base_world, object.geometry.diameter_m, object.geometry.height_m;
  return v;
}

OMapObject MakeObject(const Accumulator& a, const std::vector<ClassPrior>& classes,
                      size_t num_samples) {
  OMapObject object;
  const Vector5d mean = a.Mean();  // (4.26)/(4.27): conditional mean
  // Law of total covariance over the samples holding the identity.
  const Matrix5d covariance =
      a.covariance_sum / a.count + a.second_sum / a.count - mean * mean.transpose();
  object.base_world = mean.head<3>();
  // The solver's sizes are unconstrained least-squares values: an object seen
  // only as a sliver (a leg taken for a box) can come out a few cm below
  // zero. A size is not negative; the O-Map format bounds it at 0.
  object.diameter_m = std::max(0.0, mean[3]);
  object.height_m = std::max(0.0, mean[4]);
  object.covariance = 0.5 * (covariance + covariance.transpose());
  // The circular mean of an angle of period pi.
  if (a.yaw_count > 0)
    object.yaw_rad = 0.5 * std::atan2(a.doubled_yaw_sum.y(), a.doubled_yaw_sum.x());
  double existence_sum = 0;
  for (const auto& [sample, xi] : a.presence) existence_sum += xi;
  object.existence_probability = existence_sum / num_samples;  // (4.46) with 1/N_s
  for (const auto& [c, n] : a.class_counts)
    object.class_histogram.push_back({classes[c].name, double(n) / a.count});
  std::stable_sort(object.class_histogram.begin(), object.class_histogram.end(),
                   [](const auto& x, const auto& y) { return x.second > y.second; });
  object.class_name = classes[a.Class()].name;
  return object;
}

}  // namespace

bool FusionOptions::Validate(std::string* why) const {
  if (!(spurious_t0_m2 >= 0) || !(spurious_tau_m2 >= 0) || std::isinf(spurious_t0_m2)) {
    if (why) *why = "the spurious sigmoid needs t0 >= 0 and tau >= 0 (m^2)";
    return false;
  }
  if (!(lookalike_size_std_m > 0) || !(lookalike_base_std_m > 0) ||
      std::isinf(lookalike_size_std_m) || std::isinf(lookalike_base_std_m)) {
    if (why) *why = "the look-alike size and base spreads must be positive (m)";
    return false;
  }
  if (!(lookalike_prior > 0 && lookalike_prior < 1)) {
    if (why) *why = "the prior probability of a look-alike must be in (0, 1)";
    return false;
  }
  if (!(min_existence >= 0 && min_existence <= 1)) {
    if (why) *why = "the minimum existence probability must be in [0, 1]";
    return false;
  }
  if (!(identity_merge_distance_m >= 0) || !(identity_class_mismatch_penalty >= 1) ||
      !(identity_max_cooccurrence >= 0 && identity_max_cooccurrence <= 1)) {
    if (why)
      *why =
          "identity merging needs a distance >= 0 m, a class-mismatch penalty >= 1 and a "
          "co-occurrence fraction in [0, 1]";
    return false;
  }
  return true;
}

double MirroredSigmoid(double t, double t0, double tau) {
  if (std::isinf(t)) return 0.0;
  if (tau == 0) return t < t0 ? 1.0 : 0.0;  // the conference version's hard threshold
  return 1.0 / (1.0 + std::exp((t - t0) / tau));
}

namespace {

// The 3 x 3 location block's largest eigenvalue of the covariance whose
// information has `removed` (per parameter, 1/variance) taken away; infinity
// when what is left is not positive definite (docs/method.md §7.2 step 5).
double LocationVarianceWithout(const Matrix5d& covariance, const Vector5d& removed) {
  const double infinity = std::numeric_limits<double>::infinity();
  Eigen::LDLT<Matrix5d> ldlt(covariance);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || covariance.isZero()) return infinity;
  Matrix5d information = ldlt.solve(Matrix5d::Identity());
  information.diagonal() -= removed;
  information = 0.5 * (information + information.transpose());
  // The location block of the inverse, not the inverse of the location block:
  // the inverse of the Schur complement of the size block. A size direction
  // the detections leave free (a height censored by the mirror's rim,
  // method.md §4.2) carries no location information in a positive
  // semi-definite matrix and is marginalised by the pseudo-inverse; a
  // direction mixing range and size (one sighting) leaves the complement
  // singular, and the variance infinite (§7.2 guard).
  const double largest =
      Eigen::SelfAdjointEigenSolver<Matrix5d>(information).eigenvalues().maxCoeff();
  const double tiny = 1e-12 * largest;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> size(information.bottomRightCorner<2, 2>());
  Eigen::Vector2d size_inverse = Eigen::Vector2d::Zero();
  for (int k = 0; k < 2; ++k)
    if (size.eigenvalues()[k] > tiny) size_inverse[k] = 1.0 / size.eigenvalues()[k];
  const Eigen::Matrix<double, 3, 2> coupling = information.topRightCorner<3, 2>();
  const Eigen::Matrix3d schur = information.topLeftCorner<3, 3>() -
                                coupling * size.eigenvectors() * size_inverse.asDiagonal() *
                                    size.eigenvectors().transpose() * coupling.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> location(0.5 * (schur + schur.transpose()));
  if (!(location.eigenvalues().minCoeff() > tiny)) return infinity;  // §7.2 guard
  return 1.0 / location.eigenvalues().minCoeff();
}

}  // namespace

double PriorFreeLocationVariance(const Matrix5d& covariance, const ClassPrior& prior) {
  // (4.43): remove the prior information diag(Gamma^-1, Sigma^-1).
  Vector5d prior_variance;
  prior_variance << prior.location_std_m.array().square(), prior.size_std_m.array().square();
  return LocationVarianceWithout(covariance, prior_variance.cwiseInverse());
}

double ClassConditionedLocationVariance(const Matrix5d& covariance, const ClassPrior& prior) {
  Vector5d removed = Vector5d::Zero();
  removed.head<2>() = prior.location_std_m.head<2>().array().square().inverse();
  return LocationVarianceWithout(covariance, removed);
}

double NonSpuriousProbability(const Matrix5d& covariance, const ClassPrior& prior,
                              const FusionOptions& options) {
  if (!options.spurious_model) return 1.0;
  return MirroredSigmoid(PriorFreeLocationVariance(covariance, prior), options.spurious_t0_m2,
                         options.spurious_tau_m2);
}

namespace {

// log of the integral of exp(-theta' L theta / 2 + eta' theta) N(theta; mu,
// diag(std^2)) d theta, without the (2 pi)^(5/2) that every prior shares.
double LogPriorIntegral(const Matrix5d& information, const Vector5d& eta, const Vector5d& mu,
                        const Vector5d& std) {
  const Vector5d prior_information = std.array().square().inverse();
  Matrix5d a = information;
  a.diagonal() += prior_information;
  const Vector5d b = eta + prior_information.cwiseProduct(mu);
  const Eigen::LLT<Matrix5d> llt(a);
  const double log_det_a = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  const double log_det_prior = 2.0 * std.array().log().sum();
  return -0.5 * log_det_prior - 0.5 * log_det_a + 0.5 * b.dot(llt.solve(b)) -
         0.5 * mu.dot(prior_information.cwiseProduct(mu));
}

}  // namespace

double ClassGeometryLogBayesFactor(const Matrix5d& covariance, const Vector5d& mean,
                                   const ClassPrior& prior, const FusionOptions& options) {
  const Eigen::LDLT<Matrix5d> ldlt(covariance);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || covariance.isZero()) return 0.0;
  Vector5d mu, std;
  mu << prior.location_mean_m, prior.size_mean_m;
  std << prior.location_std_m, prior.size_std_m;
  const Vector5d prior_information = std.array().square().inverse();
  // The prior-free likelihood (4.43) in information form; a direction the
  // detections leave unconstrained (rounding can make it slightly negative)
  // has no information.
  const Matrix5d posterior_information = ldlt.solve(Matrix5d::Identity());
  Matrix5d information = posterior_information;
  information.diagonal() -= prior_information;
  information = 0.5 * (information + information.transpose());
  const Eigen::SelfAdjointEigenSolver<Matrix5d> eigen(information);
  information = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
                eigen.eigenvectors().transpose();
  const Vector5d eta = posterior_information * mean - prior_information.cwiseProduct(mu);
  Vector5d lookalike = std;
  lookalike[2] = std::max(std[2], options.lookalike_base_std_m);
  lookalike[3] = std::max(std[3], options.lookalike_size_std_m);
  lookalike[4] = std::max(std[4], options.lookalike_size_std_m);
  return LogPriorIntegral(information, eta, mu, std) -
         LogPriorIntegral(information, eta, mu, lookalike);
}

double ExistenceWeight(const Matrix5d& covariance, const Vector5d& mean, const ClassPrior& prior,
                       const FusionOptions& options) {
  if (!options.spurious_model || !options.class_geometry_evidence)
    return NonSpuriousProbability(covariance, prior, options);
  // Existence given the class (docs/method.md §7.2): the class's size and
  // support priors locate the object; the Bayes factor judges the class.
  const double p = options.existence_given_class
                       ? MirroredSigmoid(ClassConditionedLocationVariance(covariance, prior),
                                         options.spurious_t0_m2, options.spurious_tau_m2)
                       : NonSpuriousProbability(covariance, prior, options);
  if (p <= 0.0) return p;
  // Three hypotheses: spurious (the sigmoid's 1 - p), a look-alike, an
  // object of the class. How well the detections pin the object down says
  // nothing of which of the last two it is, so the Bayes factor weighs them
  // against their own prior, not against p's odds.
  const double class_log_odds = ClassGeometryLogBayesFactor(covariance, mean, prior, options) +
                                std::log1p(-options.lookalike_prior) -
                                std::log(options.lookalike_prior);
  return p / (1.0 + std::exp(-class_log_odds));
}

FusionResult FuseSamples(const std::vector<EvaluationPtr>& samples,
                         const std::vector<ClassPrior>& classes,
                         const std::vector<int>& track_sizes, const FusionOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error("O-Map fusion options: " + why);
  if (samples.empty()) throw Error("O-Map fusion: no samples");
  std::map<std::vector<int>, Accumulator> identities;
  const size_t num_poses =
      samples.front()->solution ? samples.front()->solution->trajectory.size() : 0;
  std::vector<Eigen::Vector4d> pose_sums(num_poses, Eigen::Vector4d::Zero());  // x, y, sin, cos
  for (size_t n = 0; n < samples.size(); ++n) {
    const EvaluationPtr& sample = samples[n];
    if (!sample->solution) throw Error("O-Map fusion: a sample has no geometric solution");
    const GeometricSlamResult& solution = *sample->solution;
    for (size_t i = 0; i < num_poses && i < solution.trajectory.size(); ++i) {
      const Pose2& p = solution.trajectory[i];
      pose_sums[i] += Eigen::Vector4d(p.x, p.y, std::sin(p.theta), std::cos(p.theta));
    }
    const AssociationState& state = sample->state;
    for (size_t j = 0; j < state.blocks.size(); ++j) {
      const int id = state.blocks[j].front();
      const auto object = std::find_if(solution.objects.begin(), solution.objects.end(),
                                       [id](const MappedObject& o) { return o.id == id; });
      if (object == solution.objects.end()) continue;
      Accumulator& a = identities[state.blocks[j]];
      const Vector5d v = Parameters(*object);
      ++a.count;
      a.mean_sum += v;
      a.second_sum += v * v.transpose();
      a.covariance_sum += object->covariance;
      a.presence.push_back(
          {static_cast<int>(n),
           ExistenceWeight(object->covariance, v, classes[state.classes[j]], options)});
      ++a.class_counts[state.classes[j]];
      if (object->oriented) {
        const double doubled = 2.0 * object->geometry.yaw_rad;
        a.doubled_yaw_sum += Eigen::Vector2d(std::cos(doubled), std::sin(doubled));
        ++a.yaw_count;
      }
    }
  }
  FusionResult result;
  for (size_t i = 0; i < num_poses; ++i) {
    const Eigen::Vector4d& s = pose_sums[i];  // (4.25) with a circular mean heading (#34)
    result.map.trajectory.push_back(
        {s[0] / samples.size(), s[1] / samples.size(), std::atan2(s[2], s[3])});
  }
  std::vector<Accumulator> groups;
  for (auto& [tracks, a] : identities) {
    a.members.push_back({tracks, a.count});
    groups.push_back(std::move(a));
  }
  if (options.merge_identities) groups = CombineIdentities(std::move(groups), options);
  std::vector<std::pair<OMapObject, FusedIdentity>> objects;
  for (Accumulator& a : groups) {
    OMapObject object = MakeObject(a, classes, samples.size());
    if (object.existence_probability < options.min_existence) continue;
    FusedIdentity identity;
    std::stable_sort(a.members.begin(), a.members.end(),
                     [](const auto& x, const auto& y) { return x.second > y.second; });
    for (const auto& [tracks, count] : a.members) {
      identity.tracks.insert(identity.tracks.end(), tracks.begin(), tracks.end());
      identity.members.push_back(tracks);
      identity.member_samples.push_back(count);
    }
    std::sort(identity.tracks.begin(), identity.tracks.end());
    identity.tracks.erase(std::unique(identity.tracks.begin(), identity.tracks.end()),
                          identity.tracks.end());
    identity.num_samples = static_cast<int>(a.presence.size());
    for (int t : identity.tracks) object.num_detections += track_sizes.at(t);
    objects.push_back({object, identity});
  }
  std::stable_sort(objects.begin(), objects.end(), [](const auto& x, const auto& y) {
    return x.first.existence_probability > y.first.existence_probability;
  });
  for (auto& [object, identity] : objects) {
    object.id = static_cast<int>(result.map.objects.size());
    result.map.objects.push_back(object);
    result.identities.push_back(identity);
  }
  return result;
}

}  // namespace oslam
