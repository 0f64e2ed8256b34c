// O-SLAM with unknown association on planar landmark data: sightings grouped
// into tracks (association/landmark_tracks.h), the tracks partitioned into
// landmarks by hill climbing on the Laplace log-evidence
// (association/landmark_evaluator.h), optionally sampled by MC³, and the best
// partition solved in full.
#pragma once

#include <array>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "association/association_state.h"
#include "association/landmark_evaluator.h"
#include "association/landmark_tracks.h"
#include "association/moves.h"
#include "association/rigid_alignment.h"
#include "association/sampler.h"
#include "slam/landmark_data.h"
#include "slam/landmark_noise.h"
#include "slam/landmark_slam.h"

namespace oslam {

// The whole pipeline: tracks on the dead reckoning, then hill climbing in
// growing windows of poses (each window's new tracks start separate and are
// merged into the map so far; the window is re-solved in full every
// refine_every steps and at its end), a final global hill-climbing pass on
// all poses, optionally MC³ sampling, and a full solve of the best state.
struct UnknownAssociationOptions {
  UnknownAssociationOptions() {
    moves.merge_distance_m = 3.0;
    moves.merge_sigma_m = 1.5;
  }
  LandmarkTrackOptions tracks;
  // Clutter: tracks with fewer sightings than this are explained by the
  // sensor's clutter (false detections, uniform over the field of view)
  // rather than by a landmark; they stay out of the state (association -1).
  // The clutter term is then the same for every state, so it drops out of
  // the comparisons. A birth rule as in FastSLAM / RFS-SLAM: on the raw
  // Victoria Park scans most short tracks are clutter (docs/benchmarks.md);
  // with the pre-processed sightings (with_ids) a tree is often seen once,
  // hence 1 (every track a landmark candidate) by default.
  int min_track_sightings = 1;
  // A track measures its trunk's diameter once (its mean, with
  // target.slam.diameter_std_m) instead of once per sighting: on the raw
  // Victoria Park scans the diameter's error is mostly per track (range,
  // viewing angle; consecutive scans differ by 0.08 m, tracks of one trunk
  // by about as much in their means), so per-sighting factors make two
  // tracks of one tree with 40 sightings each look like different trees.
  bool diameter_per_track = false;
  LandmarkTargetOptions target;
  // The location prior's density (target.slam.landmark_density_per_m2)
  // estimated from the data instead (SightingDensityPerM2): the default
  // density (a landmark per 6.3 hectares) makes every merge 4-6 nats cheaper
  // than on a world of a landmark per 150 m², where the true association
  // then loses to wrong loop closures (docs/benchmarks.md).
  bool landmark_density_from_data = false;
  MoveOptions moves;  // merge_distance_m / merge_sigma_m: how far apart merge candidates are
  MoveProbabilities hill_climb_moves{0.9, 0.1, 0.0};
  // Short windows: each loop closure is made (and the trajectory corrected)
  // before the drive goes on (Victoria Park, docs/benchmarks.md: with single
  // merges only, recall 0.45 with 50-pose windows on the first 2,000 poses,
  // 0.999 with 10). Under the noise calibrated on the tracks, 40-pose
  // windows keep a re-entry's tracks together long enough for their merge
  // to pay: recall 0.998 on the whole drive against 0.984 with 20, in less
  // time (docs/results.md).
  int window_poses = 40;  // 0: one window with every pose
  // A window also ends where the dead reckoning's drift since the last solve
  // (predicted std of a sighting's world position, SearchWindowEnds) reaches
  // this fraction of the landmarks' spacing (MedianCoVisibleSpacing): a new
  // track whose place is uncertain by a good part of the spacing fits its
  // neighbour's landmark as well as its own, and a window's merges are made
  // all at once. iSAM's cityTrees10000 (trees on a 5 m grid, heading drift
  // 0.01 rad per metre): 0.08-0.12 find the true trajectory, 40-pose windows
  // alone end a grid cell off (docs/benchmarks.md). 0: windows of
  // window_poses only.
  double window_drift_spacing = 0.1;
  // Poses free in a window's solves: the last free_poses of it (never fewer
  // than its new poses); the earlier ones are held at the previous window's
  // solution, so a proposal's exact solve costs what the recent drive costs.
  // The evidence is then conditional on the held poses (an approximation).
  // 0: every pose free. After the windows the whole problem is solved.
  int free_poses = 0;
  // Threads of the search (0: one per core): they measure the joint merges'
  // RANSAC samples (RigidRansacOptions::threads) and linearise the large
  // solves (SolverOptions::threads; it sets target.slam.solver.threads).
  // The result does not depend on the count.
  int threads = 0;
  double hill_climb_steps_per_track = 4;  // per window: this times its tracks
  int final_hill_climb_steps = 0;         // global pass after the windows (0: none)
  int refine_every = 50;
  // Targeted merges before each window's random moves: every landmark with a
  // track new in the window is scored against every landmark within this
  // distance (marginal mode's closed form, so tens of metres of drift since
  // the last visit are fine); the best merge of each landmark is made when it
  // raises the target, all at once, then the window is re-solved (if the
  // whole-problem target fell, only the single best is kept); repeated until
  // nothing improves. 0: off. Needs LandmarkEvaluationMode::kMarginal.
  double targeted_radius_m = 50;
  // At most this many candidates per landmark for the targeted merges, the
  // nearest ones (0: every landmark within targeted_radius_m). Bounds a
  // window's cost where landmarks are dense (clutter).
  int targeted_max_candidates = 0;
  // Duplicate sweep, after each window's targeted merges: every pair of
  // landmarks within this distance anywhere is scored (closed form) and
  // merged as the targeted merges are. Two landmarks of one tree can end up
  // centimetres apart when neither holds a new track any more (the merge
  // that would have joined them was not yet paying when their tracks were
  // new; later loop closures brought them together), and only random moves
  // would find them. 0: off.
  double sweep_radius_m = 0;
  // When a targeted merge gaining more than this (linearised) fails its
  // warm re-solve, it is re-solved once more from dead reckoning.
  double cold_retry_gain = 10;
  // Delayed decision on a weak loop closure (N-scan-back pruning of a
  // two-hypothesis tree, as in multiple-hypothesis tracking): a batch of
  // targeted merges whose re-solve raises the target by less than
  // probation_max_gain yet moves a pose by more than probation_shift_spacing
  // landmark spacings (MedianCoVisibleSpacing) re-places the robot on weak
  // evidence, where a neighbouring landmark's merge would fit nearly as well.
  // Kept at first, it is on probation: probation_windows windows later, the
  // windows since its own are run again with its pairs barred from the
  // targeted merges, and the path with the higher target at that window's
  // end goes on (bars kept with it). One probation at a time, none inside a
  // run again (docs/method.md §16.2; measured in docs/benchmarks.md).
  // probation_windows 0: off.
  int probation_windows = 0;
  double probation_max_gain = 5;
  double probation_shift_spacing = 1;
  // When a batch of targeted merges lowers the target, the merges whose
  // landmark misfits the solve (joint_misfit_z, as the joint merges' repair)
  // are undone and the rest re-solved, at most this many rounds, before
  // falling back to the single best merge (0: straight to the single best).
  // A re-entry's batch with one wrong pair among right ones then keeps the
  // right ones; the single best by gain can be the wrong one.
  int targeted_repair_rounds = 5;
  // Joint re-entry merge (a loop closure that no single merge pays for:
  // after a long drive the drift bends the whole stretch, so one sighting
  // cannot, but many together can; docs/benchmarks.md). At most every
  // joint_every_poses poses, after the window's targeted merges, the recent
  // parts of the landmarks (their tracks first seen in the last
  // joint_recent_m metres driven, placed by their own sightings: a merge made
  // under the drift may be wrong) are aligned rigidly onto the old parts
  // (tracks last seen before that) by RANSAC: joint_ransac_iterations
  // samples of two recent parts, every old pair within joint_search_m that
  // matches, rotation within joint_max_rotation_rad; inliers the mutually
  // nearest pairs within joint_inlier_m. An alignment with at least
  // joint_min_inliers inliers (a dense park offers random ones of 4-7) that
  // moves something by more than joint_inlier_m and merges something new is
  // tried: per anchor pose (joint_recent_m times 1, 2, 4, ... back,
  // joint_anchors of them, and the loop's start: joint_loop_anchor) the
  // tracks first seen after the anchor are
  // released from their landmarks, every inlier pair merged, and the whole
  // problem solved from the trajectory with the correction spread along the
  // drive since the anchor (linearly in the distance driven). The best
  // anchor's state is kept when the whole-problem evidence rises, after
  // redoing the targeted merges of the released tracks if needed; else the
  // state before is restored and, while its stretch is recent, the next
  // alignment must score joint_retry_score more. joint_min_inliers 0: off.
  int joint_min_inliers = 8;
  // In metres driven, not poses, so that the span means the same at any
  // pose rate: Victoria Park's 300 poses (0.57 m apart) were about 170 m; on
  // the synthetic city worlds (a pose per metre) 300 poses were too long a
  // stretch to align rigidly under their heading drift (docs/benchmarks.md).
  double joint_recent_m = 170;
  double joint_search_m = 60;
  double joint_inlier_m = 2.5;
  double joint_max_rotation_rad = 0.5;
  // Alignments shifting the recent landmarks by more than this are not
  // tried (0: no limit). On the raw Victoria Park drive every alignment
  // shifting them 40-56 m was a random one in the dense park, and its solve
  // (from a start tens of metres off) the most expensive; the true re-entries
  // there shift them 1-16 m.
  double joint_max_shift_m = 0;
  int joint_ransac_iterations = 300;
  int joint_anchors = 2;
  // One more anchor at the start of the loop the alignment closes: the
  // median pose at which its old landmarks were last seen. The heading drift
  // of a long loop (0.3 rad after 1.3 km) spread over the last few hundred
  // metres only bends the trajectory into a worse optimum than the drift
  // spread along the whole loop (docs/benchmarks.md).
  bool joint_loop_anchor = true;
  // RANSAC's alignment is the one with the most pairs, unless the one with
  // the most pairs weighted by fit (each exp(-d² / (2 joint_score_std_m²)))
  // scores more than joint_close_ratio times as much (0: never). A city grid
  // repeats itself every block: an alignment shifted by one collects more
  // pairs at random distances within joint_inlier_m than the first few of a
  // true re-entry, all close. A drift that bends the recent stretch leaves a
  // true alignment's far pairs loose; the plain count takes them all in.
  double joint_score_std_m = 0.8;
  double joint_close_ratio = 1.5;
  // After a refused try the next alignment's weighted score must exceed the
  // refused one's by this much (the same alignment is not tried again, a
  // better one is; asking more pairs instead locked out a true re-entry with
  // fewer pairs than a refused block-shifted one).
  double joint_retry_score = 2;
  // An alignment scoring less than this is not tried (0: any). Alignments a
  // block off in a city grid score 2-7, true re-entries 10 and more
  // (docs/benchmarks.md); each try costs two or three solves.
  double joint_min_score = 7;
  int joint_every_poses = 50;  // RANSAC at most once per this many poses
  // Small re-entries: when no alignment reaches the floors above, the
  // joint_screen_candidates best-scoring alignments with at least
  // joint_screen_min_inliers pairs are each judged by the joint merge of
  // their pairs in closed form (LandmarkEvaluator::JointMergeDelta: the
  // pairs' joint compatibility under the marginal covariance, so the drift's
  // own uncertainty bounds the shift), and the best is tried as above when it
  // gains more than joint_screen_min_gain. A few landmarks seen again after a
  // drift of a landmark spacing each have rival single merges of nearly equal
  // gain; together only the true alignment fits. joint_screen_candidates 0:
  // off; inert unless the evaluation is marginal (the closed form).
  int joint_screen_candidates = 64;
  int joint_screen_min_inliers = 4;
  double joint_screen_min_score = 4;
  double joint_screen_min_gain = 5;
  // After a joint merge's solve, the worst-fitting pairs are split off again
  // and the problem re-solved while their landmarks' standardised residuals
  // exceed joint_misfit_z, at most joint_repair_rounds times (0: never).
  int joint_repair_rounds = 5;
  double joint_misfit_z = 4;
  // Noise calibration and refinement (docs/method.md §16.3). The evidence
  // decides associations only as well as the stated noise is right: too
  // loose (GTSAM's Victoria Park file: bearing std 0.2 rad for a laser) and
  // merging landmarks metres apart pays. calibrate_on_tracks: before the
  // windows, the variance components of the sightings and the odometry are
  // estimated with every track its own landmark (the associations that are
  // certain), and the whole search runs under the calibrated noise. After
  // the windows (and MC³), calibration_rounds times (0: none), they are
  // estimated again at the association found (its outliers left out), and
  // the association is refined under that noise by split sweeps (every track
  // of a landmark scored alone, the best paying split of each landmark made)
  // and merge sweeps (every pair of landmarks within refine_radius_m), in
  // turn until neither changes anything or refine_sweeps is reached.
  bool calibrate_on_tracks = true;
  int calibration_rounds = 1;
  NoiseCalibrationOptions calibration;
  double refine_radius_m = 10;
  int refine_sweeps = 6;
  // Tracks are built before the search and stay whole in it, so a sighting
  // that continued a track by mistake (a clutter return within the track
  // gate) stays tied to the track's landmark. After the final solve, each
  // landmark's worst sighting whose squared whitened error exceeds
  // sighting_split_gate (2 degrees of freedom; only those within a factor 4
  // of the round's worst, as in data snooping) becomes a landmark of its
  // own, and the split is kept when the whole problem's evidence rises (else
  // the single worst is tried alone); at most sighting_split_rounds rounds
  // (0: off). Not with diameter_per_track (a track's one diameter would go
  // with the sighting that carries it).
  double sighting_split_gate = 25;
  int sighting_split_rounds = 5;
  // Before the splits, two landmarks that share a scan are tried joined
  // when their places differ by at most this, in squared sigmas of their
  // covariances given the poses (their sightings' own information). Those
  // leave out how the poses of the scans the two do not share may differ,
  // so the gate is wider than the splits' (10,000-pose world: 25 missed two
  // of the joins the marginal covariances found, 100 finds them all).
  double shared_scan_join_gate = 100;
  int samples = 0;  // MC³ iterations after hill climbing (0: hill climbing only)
  int burn_in = 0;
  int num_chains = 2;
  unsigned long seed = 1;
  // Landmark location prior N(centre, prior_std^2 I): the centre is the mean
  // of the sightings placed by dead reckoning; std from target.slam.
  bool Validate(std::string* why) const;
};

struct UnknownAssociationResult {
  std::vector<std::vector<int>> tracks;
  AssociationState state;  // the best state of tracks found (before the sighting splits)
  // Per sighting: ids = the earliest track of the landmark; a sighting split
  // off its track (sighting_split_gate) num_tracks + j; -1 clutter.
  std::vector<int> association;
  LandmarkSlamResult solution;  // full solve of `state`, landmark covariances
  double log_target = 0;        // of `state`, full evaluation
  long proposals = 0, accepted = 0, solves = 0, cache_hits = 0, cold_retries = 0;
  long joint_tries = 0, joint_merges = 0;      // joint re-entry merges: solves tried, pairs kept
  long probations = 0, probations_undone = 0;  // weak loop closures decided, and undone
  long clutter_tracks = 0, clutter_sightings = 0;  // left out (min_track_sightings)
  // Landmarks split at a window start because two of their tracks, merged
  // before, both continued into one scan (one sighting per scan).
  long scan_splits = 0;
  double track_time_s = 0, hill_climb_time_s = 0, sampling_time_s = 0, total_time_s = 0;
  double proposal_time_s = 0;  // spent evaluating proposals (hill climbing)
  double joint_time_s = 0;     // spent on joint re-entry merges (RANSAC, solves, re-merges)
  long refines = 0;            // full solves of the windows' states (hill climbing)
  double refine_time_s = 0;    // spent in them
  double targeted_time_s = 0;  // spent scoring targeted merges
  // Noise calibration: the scales of the stated noise (product over the
  // rounds), the refinement's splits and merges, and its time.
  NoiseScales noise_scales;
  // The model the search scored under, as known-association options (the
  // landmark location prior centred on the sightings included; no
  // covariances): another association solved with these on
  // WithNoiseScales(data, noise_scales) has a comparable evidence and
  // trajectory.
  LandmarkSlamOptions slam_options;
  long refine_splits = 0, refine_merges = 0;
  long sighting_splits = 0;    // sightings split off their tracks (sighting_split_gate)
  long leverage_splits = 0;    // of them, high-leverage ones (HighLeverageTracks)
  long shared_scan_joins = 0;  // landmark pairs joined across a shared scan (the same)
  double calibration_time_s = 0;
  SamplerSummary sampler;  // when samples > 0
};

using LandmarkProgress = std::function<void(const std::string& line)>;

// The RANSAC options of the joint re-entry merges (the joint_* options).
RigidRansacOptions JointRansacOptions(const UnknownAssociationOptions& options);

// Throws oslam::Error on invalid options or an unsolvable start.
UnknownAssociationResult SolveUnknownAssociation(const LandmarkDataset& data,
                                                 const UnknownAssociationOptions& options,
                                                 const LandmarkProgress& progress = {});

// One solve of SolveUnknownAssociation: its phases as methods sharing the
// search's state (the current evaluation, the window's evaluator, the random
// stream), in the order Run() calls them.
class LandmarkAssociation {
 public:
  // `data` must outlive the object. Throws oslam::Error on invalid options.
  LandmarkAssociation(const LandmarkDataset& data, const UnknownAssociationOptions& options,
                      LandmarkProgress progress = {});
  // Once per object (else throws oslam::Error). Throws oslam::Error on an
  // unsolvable start.
  UnknownAssociationResult Run();

 private:
  // The recent or the old part of a landmark, for the joint re-entry merges.
  struct Unit {
    std::vector<int> tracks;
    Eigen::Vector2d position_m = Eigen::Vector2d::Zero();
  };
  // A joint re-entry merge found by RANSAC: recent units matched to old ones.
  struct JointAlignment {
    std::vector<Unit> recent, old;
    RigidMatch match;                                 // from recent onto old units
    Eigen::Vector2d pivot = Eigen::Vector2d::Zero();  // mean of the matched recent units
  };
  struct MergeCandidate {
    double delta;              // linearised gain in log target
    int a, b;                  // blocks of the current state
    EvaluationPtr evaluation;  // the merged state's; BestMerges fills the best one's
  };

  // Tracks on the dead reckoning, clutter left out, the location prior's
  // centre, the windows' ends.
  void BuildTracks();
  void PlanWindows();
  // The search's state before a window: all that RunWindow reads of the
  // windows before (its evaluator is built anew), to run it again.
  struct WindowStart {
    size_t window = 0;
    AssociationState state;
    EvaluationPtr previous;
    int tracks_before = 0;
    Rng rng;
    OrderingType compared_ordering = OrderingType::kAutomatic;
    int ordering_compared_poses = -1;
    int last_ransac = 0;
    double joint_needed_score = 0;
    int last_failure = 0;
  };
  // A weak loop closure kept for now (probation_windows): the windows from
  // `start` are run again without its merges (pairs of tracks) after window
  // decide_after.
  struct Probation {
    WindowStart start;
    std::vector<std::pair<int, int>> pairs;
    size_t decide_after = 0;
  };
  // The whole search path after a window, the window's evaluator included,
  // set aside while the windows are run again.
  struct SearchPath {
    WindowStart start;  // the state after the window, as the next one reads it
    EvaluationPtr current;
    int tracks_now = 0, held_poses = 0;
    long split_pairs = 0;
    std::unique_ptr<LandmarkDataset> window_dataset;
    std::unique_ptr<LandmarkTargetData> window_data;
    std::unique_ptr<LandmarkEvaluator> evaluator;
  };

  // The windows in turn, each weak loop closure decided by running its
  // windows again without it (Probation).
  void RunWindows();
  WindowStart SaveWindowStart(size_t w) const;
  void RestoreWindowStart(const WindowStart& start);
  SearchPath TakePath();
  void PutPath(SearchPath path);
  void DecideProbation(size_t w);
  // After a paying batch of targeted merges: notes its pairs as a weak loop
  // closure when it gained little but moved a pose far.
  void NoteWeakClosure(const StateEvaluation& before, const StateEvaluation& after,
                       const std::vector<std::pair<int, int>>& pairs);
  // A window: its start state and first solve, targeted merges, duplicate
  // sweep, joint re-entry merge, random hill climbing.
  void RunWindow(size_t w);
  void StartWindow(size_t w);
  void OpenWindowProblem(int n, int previous_end);
  // The fill-reducing ordering kind of window solves of n poses, and the
  // kind a window's first solve used (WindowOrdering, NoteOrdering).
  OrderingType WindowOrdering(int n) const;
  void NoteOrdering(int n, const StateEvaluation& solved);
  void SplitSharedScans(int previous_end, int n);
  // Random greedy moves, re-solved after each accepted one (marginal mode)
  // and every refine_every steps; returns the moves accepted.
  long HillClimb(long steps);
  // Targeted merges of the landmarks holding tracks >= first_new; the
  // duplicate sweep: the same for every pair of landmarks within
  // sweep_radius_m. Both return the merges made.
  long TargetedMerges(int first_new);
  long DuplicateSweep();
  long MergeRounds(int first_new, double sweep_m);
  std::vector<MergeCandidate> BestMerges(int first_new, double sweep_m);
  std::vector<std::pair<double, int>> MergeCandidatesOf(size_t j, int first_new,
                                                        double sweep_m) const;
  bool MakeMerges(const std::vector<MergeCandidate>& best, double sweep_m, int* made);
  EvaluationPtr WithoutMisfitMerges(EvaluationPtr e, const AssociationState& before,
                                    std::vector<std::pair<int, int>>* pairs, int* made);
  static AssociationState WithBlockPairsMerged(const AssociationState& s,
                                               const std::vector<std::pair<int, int>>& pairs);
  double MisfitZ(const StateEvaluation& e, int j) const;
  // Joint re-entry merge at window end n; returns the pairs merged.
  long JointMerge(int n);
  long TryJointMerge(int n);
  JointAlignment RecentAndOldUnits(const StateEvaluation& before, int n) const;
  std::optional<JointAlignment> AlignRecentOntoOld(const StateEvaluation& before, int n);
  std::optional<JointAlignment> ScreenedAlignment(const StateEvaluation& before, int n);
  bool JointGainOfBestPairs(const StateEvaluation& at, const JointAlignment& units, int n,
                            RigidMatch* match, double* gain);
  // The groups of `s`'s blocks that `match` merges (its pairs of whole
  // recent landmarks with old ones that share no scan), for JointMergeDelta;
  // `scans` caches each block's sorted poses across calls on `s`.
  std::vector<std::vector<int>> MergedGroups(const AssociationState& s, const JointAlignment& units,
                                             const RigidMatch& match, int n,
                                             std::map<int, std::vector<int>>* scans) const;
  bool WorthATry(const AssociationState& s, JointAlignment* alignment) const;
  EvaluationPtr TryAnchor(const StateEvaluation& before, const JointAlignment& alignment,
                          const std::vector<double>& driven, int anchor, int n);
  EvaluationPtr WithoutMisfitPairs(EvaluationPtr e, const JointAlignment& alignment);
  AssociationState ReleasedAndMerged(const AssociationState& s, const JointAlignment& alignment,
                                     int anchor) const;
  int LoopStart(const JointAlignment& alignment) const;
  long KeepJointMerge(const EvaluationPtr& before, const EvaluationPtr& best, int best_anchor,
                      int n, const JointAlignment& alignment);
  // The first pose within `metres` driven (by the dead reckoning) of pose
  // n - 1: the start of the stretch that long ending at pose n.
  int StretchStart(int n, double metres) const;
  // Warm-start places of `state`'s landmarks after the tracks first seen
  // after `anchor` were released from `before`'s.
  std::vector<Eigen::Vector3d> SeedLocations(const StateEvaluation& before,
                                             const AssociationState& state,
                                             const std::vector<Pose2>& trajectory, int anchor,
                                             int n) const;
  // Where the sightings of `tracks` before pose n put their landmark.
  Eigen::Vector2d PlacedBy(const std::vector<int>& tracks, const std::vector<Pose2>& poses,
                           int n) const;
  // After the windows: every pose freed, the final sweep, the global pass.
  void FinalGlobalPass();
  // Before the windows: the noise calibrated with every track its own
  // landmark; data_ becomes the calibrated data set.
  void CalibrateOnTracks();
  // Noise calibration at `best`'s association and the split and merge
  // sweeps under the calibrated noise; the refined state's evaluation.
  EvaluationPtr CalibrateAndRefine(EvaluationPtr best);
  // Rounds of the best paying split of each landmark (one track alone);
  // returns the splits made.
  long SplitSweep();
  // MC³ from the hill-climbing state; the better of its best and `best`.
  EvaluationPtr SampleMc3(EvaluationPtr best);
  void FinalSolve(const EvaluationPtr& best);
  // The sighting splits (sighting_split_gate) on result_'s association.
  void SplitMisfitSightings();
  // Before them: two landmarks agreeing in place within the gate but sharing
  // a scan (one sighting per scan forbids their merge) tried joined with,
  // in each shared scan, the sighting farther from their joint place split
  // off; kept when the evidence rises. Returns the pairs joined.
  long JoinAcrossSharedScans(LandmarkSlam* slam, int* next_id);
  // In the refinement: the high-leverage one-sighting tracks of the current
  // state (HighLeverageTracks on its association) each tried alone in a
  // landmark of its own by a full solve, so that the sweeps after it can
  // merge what the turned map had kept apart; returns the splits made.
  long LeverageSplits();
  // Whether the sighting-level splits run: a gate and rounds > 0, no
  // per-track diameters.
  bool SightingSplitsOn() const;
  // The one-sighting tracks the solve bent the map to fit: each in a
  // landmark with others, its sighting's deleted residual (its error against
  // the solve without it, from the joint covariance of its pose and
  // landmark) above sighting_split_gate while its residual is not; worst
  // first.
  std::vector<int> HighLeverageTracks(LandmarkSlam* slam, const std::vector<int>& association,
                                      const LandmarkSlamResult* warm_start);
  // Solves `trial` (an association of result_'s sightings with `splits`
  // sightings split off) and makes it result_'s when its evidence is higher.
  bool KeepIfBetter(LandmarkSlam* slam, std::vector<int> trial, long splits);
  // A full solve of a window's state, timed.
  EvaluationPtr Refine(const AssociationState& state, const StateEvaluation* from);
  void Say(const std::string& line) const;

  const LandmarkDataset& input_;
  bool ran_ = false;
  UnknownAssociationOptions options_;  // the location prior's centre set from the tracks
  LandmarkProgress progress_;
  std::chrono::steady_clock::time_point start_, climb_start_;
  UnknownAssociationResult result_;

  LandmarkDataset per_track_;                // diameter_per_track: the diameters per track
  LandmarkDataset calibrated_;               // stated_ with result_.noise_scales
  const LandmarkDataset* stated_ = nullptr;  // the stated noise: input_ or per_track_
  const LandmarkDataset* data_ = nullptr;    // stated_ or calibrated_
  int num_tracks_ = 0;
  std::vector<int> first_pose_, last_pose_, track_size_;  // per track
  std::vector<double> driven_m_;  // per pose: metres driven since pose 0 (dead reckoning)
  std::optional<ClassConfusionModel> model_;
  std::vector<int> ends_;  // of the windows (pose counts)
  double spacing_m_ = 0;   // MedianCoVisibleSpacing, when an option needs it

  Rng rng_;
  AssociationState state_;  // the last window's (or the global pass's) final state
  EvaluationPtr previous_;  // the last window's final full solve
  EvaluationPtr current_;
  long split_pairs_ = 0;                    // by the last WithoutMisfitPairs
  int tracks_before_ = 0, tracks_now_ = 0;  // tracks of the earlier windows, and with this one
  std::array<MoveStatistics, kNumMoveTypes> stats_{};
  // The window's data, kept alive as long as its evaluator.
  std::unique_ptr<LandmarkDataset> window_dataset_;
  std::unique_ptr<LandmarkTargetData> window_data_;
  std::unique_ptr<LandmarkEvaluator> evaluator_;
  int held_poses_ = 0;  // the current window's (free_poses)
  // The ordering kind the last comparison chose and its window's poses
  // (-1: none yet).
  OrderingType compared_ordering_ = OrderingType::kAutomatic;
  int ordering_compared_poses_ = -1;

  int last_ransac_;                // window end of the last RANSAC
  double joint_needed_score_ = 0;  // RANSAC score the next joint merge needs
  int last_failure_ = 0;

  // Probation (probation_windows): the window's weak loop closures (pairs of
  // tracks), the one on probation, the pairs the targeted merges do not
  // join, and whether windows are being run again.
  std::vector<std::pair<int, int>> weak_closures_;
  std::optional<Probation> probation_;
  std::vector<std::pair<int, int>> barred_;
  bool replaying_ = false;
};

}  // namespace oslam
