// The sampler's target for O-SLAM with unknown association on planar
// landmark data: the state is a partition of the tracks
// (association/landmark_tracks.h) into landmarks (one class, "tree"), and the
// target is LandmarkSlam's Laplace log-evidence with a landmark location
// prior (so states with different landmark counts compare).
//
// Two evaluations of a proposed state:
//  * exact: the whole problem (all poses and landmarks) re-solved from the
//    current state's solution with a few Levenberg-Marquardt iterations, its
//    evidence the target (docs/method.md §9.6);
//  * local (approximation): the poses are held at the trajectory of the last
//    full solve (the reference state R, refined every K steps). Given the
//    poses the landmarks are independent, so the log-evidence splits into a
//    sum over landmarks; a state S scores
//        log_target(R) + sum_{b in S \ R} L(b) - sum_{b in R \ S} L(b),
//    where L(b) is the Laplace log-evidence of landmark b alone (its
//    sightings, the location prior, poses fixed). Only the landmarks a move
//    changes are solved (2-D problems of their sightings), so a proposal
//    costs the same at any trajectory length. It ignores the pose
//    uncertainty (how much a merge would bend the trajectory), which is why
//    the driver (pipeline/landmark_association.h) works in growing temporal
//    windows: the poses a new track is seen from are then only a short drive
//    from well-estimated ones.
#pragma once

#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "association/association_state.h"
#include "association/sampler.h"
#include "core/pair_key.h"
#include "slam/landmark_slam.h"

namespace oslam {

// kMarginal (for hill climbing): a merge of two landmarks of the reference
// (the last full solve) is scored in closed form from their joint marginal
// covariance at the reference, i.e. the exact answer of the linearised
// problem (one linear system, docs/method.md §9.6), pose uncertainty and loop
// correlations included; other proposals as kLocal. The driver re-solves
// after each accepted move so the next merge is again against a reference.
enum class LandmarkEvaluationMode { kExact, kLocal, kMarginal };

struct LandmarkTargetOptions {
  // The density of a 100 m Gaussian prior at its centre, 1 / (2 pi 100^2):
  // a landmark per 6.3 hectares. Every merge pays log(1 / density) for the
  // landmark it saves, less what it costs in fit; a higher density makes
  // merges dearer (Victoria Park with ids hidden: 160 landmarks for 151 at
  // this density, 164 and recall 0.984 at 1e-3, docs/benchmarks.md).
  static constexpr double kDefaultLandmarkDensityPerM2 = 1.5915494309189535e-05;
  LandmarkTargetOptions() { slam.landmark_density_per_m2 = kDefaultLandmarkDensityPerM2; }
  // The full solves (Refine, and exact proposals with fewer iterations).
  // A location prior is required: landmark_density_per_m2 or
  // landmark_prior_std_m > 0.
  LandmarkSlamOptions slam;
  LandmarkEvaluationMode mode = LandmarkEvaluationMode::kMarginal;
  int proposal_iterations = 5;  // exact: LM iterations of a proposal's warm re-solve
  int local_iterations = 10;    // local: LM iterations of one landmark's solve
  size_t max_cache_entries = 5000;
  // A scan sees a landmark at most once: a state putting two sightings of
  // one pose on one landmark is invalid (P = 0), so no such merge is made.
  bool one_sighting_per_scan = true;

  bool Validate(std::string* why) const;
};

struct LandmarkTargetData {
  const LandmarkDataset* data = nullptr;
  std::vector<std::vector<int>> tracks;  // sighting indices into *data
};

// The evaluations: locations (x, y, 0) and residual2 per block; solution
// holds the trajectory they belong to (a full solve's own, for local ones the
// reference's) and no objects.
class LandmarkEvaluator : public StateEvaluator {
 public:
  // data (and its data set) must outlive the evaluator. Throws oslam::Error
  // on invalid options.
  LandmarkEvaluator(const LandmarkTargetData& data, const LandmarkTargetOptions& options);

  EvaluationPtr Evaluate(const AssociationState& state, const StateEvaluation* from) override;
  EvaluationPtr Refine(const AssociationState& state, const StateEvaluation* from) override;
  void Remember(const EvaluationPtr& evaluation) override;
  size_t num_solves() const override { return solves_; }
  size_t num_cache_hits() const override { return hits_; }
  size_t num_marginal_merges() const { return marginal_merges_; }  // marginal: closed-form merges
  // Whether `evaluation` is the reference: the last full optimisation
  // (Refine), so solving its state again would change nothing.
  bool IsReference(const StateEvaluation& evaluation) const {
    return reference_.get() == &evaluation;
  }

  // The landmark id of every sighting under `state` (a block's id is its
  // earliest track), -1 for sightings in no track.
  std::vector<int> Association(const AssociationState& state) const;
  // A full solve of `state` (the refine iterations) from `from` that leaves
  // the reference (and so the marginal merges) alone: for trying a state far
  // from the current one, e.g. a joint re-entry merge, before Refine-ing it.
  EvaluationPtr Trial(const AssociationState& state, const StateEvaluation* from);
  // Marginal mode: the reference's blocks `blocks` are about to be scored
  // in merges with each other; their covariance roots are computed in one
  // batch (a forward solve per 64 columns) so that each pair's joint
  // covariance is a product of kept columns instead of a solve of its own.
  void PrepareMerges(const std::vector<int>& blocks);
  // Marginal mode, `at` the reference: what Evaluate gives for `at` with its
  // blocks ja and jb merged, minus at's log target, without building that
  // state (the targeted merges score thousands of pairs per window);
  // -infinity when the merged landmark would have two sightings of one scan.
  // False when the closed form does not apply: Evaluate the state then.
  bool MergeGain(const StateEvaluation& at, int ja, int jb, double* gain);
  // Local or marginal mode, `at` the reference: what Evaluate gives for `at`
  // with track `track` split off its block j into a landmark of its own,
  // minus at's log target, without building that state (the refinement
  // sweep scores a split of every track); -infinity when the rest of the
  // block would have two sightings of one scan. False when this does not
  // apply (exact mode, not the reference, the track not in block j or
  // alone in it): Evaluate the state then.
  bool SplitGain(const StateEvaluation& at, int j, int track, double* gain);
  // Marginal mode, `state` the reference: log_target(merged) -
  // log_target(reference) in closed form, linearised at the reference, for
  // merging each group of the reference's blocks `groups` (indices into
  // state.blocks, disjoint, at least two each) into one landmark, trunk
  // diameters included: the joint
  // compatibility of several merges at once (docs/method.md §16.2). False
  // when not computable (not the reference, a key without a position).
  bool JointMergeDelta(const AssociationState& state, const std::vector<std::vector<int>>& groups,
                       double* delta);
  // `from`'s solution as a known-association start for Association(
  // from.state) (ids: each landmark's earliest track).
  LandmarkSlamResult WarmStart(const StateEvaluation& from) const;
  // The full solution of `state` with landmark covariances, warm-started
  // from `from` when given (for the output map).
  LandmarkSlamResult Solve(const AssociationState& state, const StateEvaluation* from);

  // Sets the reference aside with its factor and everything computed at it
  // (marginal mode's covariances, the caches): the next Refine makes a new
  // reference in a second solver, and RestoreReference brings this one
  // back without a solve. For judging a state far from the current one in
  // closed form and returning to the current one (a joint re-entry
  // screen). One reference at a time is set aside.
  void StashReference();
  // The reference set aside becomes the reference again (the one made
  // since is dropped); returns its evaluation. Only after StashReference.
  EvaluationPtr RestoreReference();

 private:
  struct BlockValue {
    double log_evidence = 0, residual2 = 0;
    Eigen::Vector2d position_m = Eigen::Vector2d::Zero();
  };
  struct BlockHash {
    size_t operator()(const std::vector<int>& block) const;
  };
  enum class Solver { kStep, kRefine, kTrial };
  EvaluationPtr FullEvaluation(const AssociationState& state, const StateEvaluation* from,
                               Solver solver);
  EvaluationPtr LocalEvaluation(const AssociationState& state, const StateEvaluation* from);
  // Marginal mode: when `state` is the reference with two of its blocks
  // merged, fills `evaluation` in closed form and returns true.
  bool MarginalMergeEvaluation(const AssociationState& state, StateEvaluation* evaluation);
  const BlockValue& LocalBlock(const std::vector<int>& block, const StateEvaluation* from);
  void Store(const EvaluationPtr& evaluation);
  std::vector<int> SightingsOf(const std::vector<int>& block) const;

  const LandmarkTargetData& data_;
  LandmarkTargetOptions options_;
  std::unique_ptr<LandmarkSlam> full_;  // Refine's solver: its factor is the reference's
  LandmarkSlam step_, trial_;
  SparseSolver local_solver_;
  std::unordered_map<AssociationState, EvaluationPtr, AssociationStateHash> cache_;
  // Local mode: the reference (last full solve) and L(b) at its trajectory.
  EvaluationPtr reference_;
  bool reference_factorised_ = false;         // reference_ is full_'s last solve
  std::vector<int> reference_position_keys_;  // per reference block
  std::vector<int> last_refine_keys_;         // per block of full_'s last solve
  std::unordered_map<std::vector<int>, int, BlockHash> reference_blocks_;  // block -> index
  std::unordered_map<std::vector<int>, BlockValue, BlockHash> block_cache_;
  void SetReference(const EvaluationPtr& evaluation);
  // True when two of the block's sightings are from one pose.
  bool SharesAScan(const std::vector<int>& block) const;
  // log_target(merged) - log_target(reference) for merging reference blocks
  // ja and jb, and the merged landmark's mean; false when not computable.
  bool MergeDelta(int ja, int jb, double* delta, Eigen::Vector2d* mean);
  // The 4 x 4 joint covariance of the landmark positions at solver keys ka
  // and kb at the reference: from kept roots when both are, else solved.
  bool JointCovariance(int ka, int kb, Eigen::Matrix4d* sigma);
  // The trunk diameters' part of merging the reference's blocks `group`
  // into one (MergeDelta, JointMergeDelta; 0 unless two have one).
  double DiameterMergeDelta(const std::vector<int>& group) const;
  struct PriorTerms {
    double information = 0;  // taken off the merged position's information (times I)
    Eigen::Vector2d information_mean = Eigen::Vector2d::Zero();
    double log_term = 0;
  };
  PriorTerms PriorTermsOf(int extra) const;
  size_t solves_ = 0, hits_ = 0, marginal_merges_ = 0;
  // Covariance roots (SparseSolver::CovarianceRoots) of landmark positions
  // at the reference's factor, by solver key; at most kMaxRootBytes kept.
  std::unordered_map<int, CovarianceRoot> roots_;
  double root_bytes_ = 0;
  static constexpr double kMaxRootBytes = 256e6;
  // JointMergeDelta: the 4 x 4 joint covariances of key pairs (lower key
  // first) at the reference's factor.
  struct KeyPairHash {
    size_t operator()(const std::pair<int, int>& keys) const {
      return std::hash<long long>()(PairKey(keys.first, keys.second));
    }
  };
  std::unordered_map<std::pair<int, int>, Eigen::Matrix4d, KeyPairHash> cross_covariances_;
  static constexpr size_t kMaxCrossCovariances = 1 << 20;

  // The members above that belong to a reference, set aside by
  // StashReference (full: the second solver while none is).
  struct StashedReference {
    std::unique_ptr<LandmarkSlam> full;
    EvaluationPtr reference;
    bool factorised = false, held = false;
    std::vector<int> position_keys, last_refine_keys;
    std::unordered_map<std::vector<int>, int, BlockHash> blocks;
    std::unordered_map<std::vector<int>, BlockValue, BlockHash> block_cache;
    std::unordered_map<AssociationState, EvaluationPtr, AssociationStateHash> cache;
    std::unordered_map<int, CovarianceRoot> roots;
    double root_bytes = 0;
    std::unordered_map<std::pair<int, int>, Eigen::Matrix4d, KeyPairHash> cross_covariances;
  };
  // Empty but for its solver while no reference is held (RestoreReference
  // empties it).
  StashedReference stash_;
  void SwapWithStash();
};

// Squared whitened range-bearing residuals of the sightings `sightings` of a
// landmark at `landmark_m`, seen from `trajectory`.
double SightingResidual2(const LandmarkDataset& data, const std::vector<Pose2>& trajectory,
                         const std::vector<int>& sightings, const Eigen::Vector2d& landmark_m);

}  // namespace oslam
