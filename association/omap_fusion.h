// The O-Map from samples {(C_n, J_n)} (docs/method.md §7.3 Algorithm 3, with the
// review's fixes §13 #9, #10, #33-#36): identities are sets of tracks; per
// identity the existence probability pi = (1/N_s) sum_n 1(ID in n) P(xi),
// the conditional mean geometry over the samples holding it, a covariance
// (mean of the per-sample covariances plus the spread of the means), and the
// class histogram whose most frequent class is the object's class. P(xi) is
// the spurious-object model of docs/method.md §7.2 (mirrored sigmoid on the location
// uncertainty with the class prior removed).
//
// Beyond the thesis (docs/method.md §7.3, identity merging; §12): one physical object can
// appear under different identities in different samples (one extra track
// attached to it, or its tracks grouped differently). Identities whose mean
// base points are within a class-aware distance and that rarely appear in
// the same sample are combined into one map object: its pi is the share of
// samples holding any of them (each sample counted once, with the largest
// P(xi) among the members it holds), its geometry and class histogram pool
// the members' samples (a mean weighted by sample counts).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "association/association_state.h"
#include "omap/omap.h"
#include "slam/geometric_slam.h"

namespace oslam {

struct FusionOptions {
  double spurious_t0_m2 = 0.16;   // t0 = (0.4 m)^2
  double spurious_tau_m2 = 0.04;  // tau = (0.2 m)^2
  bool spurious_model = true;     // false: P(xi) = 1 (setup 2, Fig. 6.9)
  // Beyond the thesis (docs/method.md §7.2, class geometry evidence): a
  // consistently detected object is of its class or a look-alike. P(xi)
  // (the sigmoid: is it consistent?) times P(class | consistent), from the
  // Bayes factor of the object's prior-free geometry under its class's
  // priors (size; location, with any support prior) against a look-alike's,
  // whose diameter and height have this spread about the class's means and
  // whose base height at least lookalike_base_std_m, and the prior
  // probability lookalike_prior of a look-alike. false: the thesis' P(xi).
  bool class_geometry_evidence = true;
  double lookalike_size_std_m = 1.0;
  double lookalike_base_std_m = 2.0;  // the thesis' Gamma_z (§13 #7)
  double lookalike_prior = 0.5;       // no preference, in (0, 1)
  // Beyond the thesis (docs/method.md §7.2, existence given the class): the
  // location uncertainty of the sigmoid keeps the class's size prior and the
  // base-height part of its location prior and removes only the horizontal
  // location prior: under the class hypothesis an object seen from one place
  // (the robot turning on the spot) is located by its apparent size and the
  // elevation of its base, and whether the class holds is judged by the class
  // geometry evidence. Only with class_geometry_evidence. false: (4.43), every
  // class prior removed.
  bool existence_given_class = false;
  double min_existence = 0.0;  // identities below this pi are left out of the map

  // Identity merging (docs/method.md §7.3); false = the thesis' Algorithm 3 as printed.
  bool merge_identities = true;
  double identity_merge_distance_m = 0.5;  // d_thr of the merge move (Sec. 6.2)
  // Squared distance times this factor when the identities' classes differ
  // (as the merge proposal's e_j); infinity = only identities of one class.
  double identity_class_mismatch_penalty = 3.0;
  // Two (groups of) identities are combined only when they appear together
  // in at most this fraction of the samples of the rarer of them.
  double identity_max_cooccurrence = 0.1;

  bool Validate(std::string* why) const;
};

// S(t) = 1 / (1 + exp((t - t0) / tau)).
double MirroredSigmoid(double t, double t0, double tau);

// ||C̄_l||_2 (m^2) of docs/method.md §7.2: the location block of the prior-free
// covariance; infinity when the prior-free information is not positive definite.
double PriorFreeLocationVariance(const Eigen::Matrix<double, 5, 5>& covariance,
                                 const ClassPrior& prior);
// The same with only the horizontal location prior removed (the size prior
// and the base height's prior kept: FusionOptions::existence_given_class).
double ClassConditionedLocationVariance(const Eigen::Matrix<double, 5, 5>& covariance,
                                        const ClassPrior& prior);

double NonSpuriousProbability(const Eigen::Matrix<double, 5, 5>& covariance,
                              const ClassPrior& prior, const FusionOptions& options);

// log of the Bayes factor (docs/method.md §7.2, class geometry evidence) of
// an object's geometry under its class's priors against a look-alike's: the
// prior-free Gaussian likelihood of theta = (l, g) (posterior `covariance`
// and `mean` with the class prior's information removed, as (4.43)),
// integrated against each prior. 0 when the covariance is not positive
// definite.
double ClassGeometryLogBayesFactor(const Eigen::Matrix<double, 5, 5>& covariance,
                                   const Eigen::Matrix<double, 5, 1>& mean, const ClassPrior& prior,
                                   const FusionOptions& options);

// P(xi) of the object: NonSpuriousProbability, times the probability that a
// consistent object is of its class rather than a look-alike when
// options.class_geometry_evidence.
double ExistenceWeight(const Eigen::Matrix<double, 5, 5>& covariance,
                       const Eigen::Matrix<double, 5, 1>& mean, const ClassPrior& prior,
                       const FusionOptions& options);

struct FusedIdentity {
  std::vector<int> tracks;  // the identity (with merged identities: the union of their tracks)
  int num_samples = 0;      // samples that hold it (any of its members)
  // The sample identities combined into this object, most frequent first
  // (one entry, equal to `tracks`, when nothing was merged).
  std::vector<std::vector<int>> members;
  std::vector<int> member_samples;  // samples holding each member
};

struct FusionResult {
  OMap map;                               // objects sorted by pi, highest first; id = rank
  std::vector<FusedIdentity> identities;  // parallel to map.objects
};

// track_sizes[t] = detections of track t. Throws oslam::Error when a sample
// has no solution or no samples are given.
FusionResult FuseSamples(const std::vector<EvaluationPtr>& samples,
                         const std::vector<ClassPrior>& classes,
                         const std::vector<int>& track_sizes, const FusionOptions& options);

}  // namespace oslam
