// oslam map --landmarks FILE: planar landmark SLAM (issue 10) on a range-
// bearing data set, the association taken from the file's landmark ids
// (GTSAM format) or from an association file. Writes the O-Map (trees as
// objects) and the trajectory CSV.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "association/association_metrics.h"
#include "core/atomic_file.h"
#include "core/csv.h"
#include "core/error.h"
#include "omap/omap_json.h"
#include "pipeline/landmark_association.h"
#include "slam/landmark_data.h"
#include "slam/landmark_slam.h"
#include "slam/slam_omap.h"

namespace oslam {

namespace {

std::string TrajectoryCsv(const LandmarkDataset& data, const LandmarkSlamResult& result) {
  std::ostringstream out;
  const bool times = static_cast<int>(data.pose_times.size()) == data.num_poses;
  out << "pose,pose_id," << (times ? "time_s," : "") << "x_m,y_m,theta_rad\n";
  for (int i = 0; i < data.num_poses; ++i) {
    const Pose2& p = result.trajectory[i];
    out << i << ',' << data.pose_ids[i] << ',';
    if (times) out << CsvNumber(data.pose_times[i]) << ',';
    out << CsvNumber(p.x) << ',' << CsvNumber(p.y) << ',' << CsvNumber(p.theta) << '\n';
  }
  return out.str();
}

std::string OutputTrajectoryPath(const Arguments& arguments) {
  return arguments.Has("trajectory")
             ? arguments.Get("trajectory")
             : (std::filesystem::path(arguments.Get("output")).parent_path() / "trajectory.csv")
                   .string();
}

void PrintGpsError(const Arguments& arguments, const LandmarkDataset& data,
                   const std::vector<Pose2>& trajectory) {
  if (!arguments.Has("gps")) return;
  if (static_cast<int>(data.pose_times.size()) != data.num_poses)
    throw Error::InFile(data.path, "--gps needs pose times, which this format has not");
  const std::vector<GpsFix> gps = ReadGps(arguments.Get("gps"));
  const GpsError e = CompareWithGps(trajectory, data.pose_times, gps);
  const GpsError d = CompareWithGps(data.dead_reckoning, data.pose_times, gps);
  std::printf(
      "vs GPS (%d fixes, rigid alignment): RMSE %.2f m, median %.2f m, max %.2f m (dead "
      "reckoning: RMSE %.2f m, median %.2f m, max %.2f m)\n",
      e.num_fixes, e.rmse_m, e.median_m, e.max_m, d.rmse_m, d.median_m, d.max_m);
}

// --unknown-association: the file's ids are hidden from the solve and used
// only to score it.
int RunUnknownAssociation(const Arguments& arguments, const LandmarkDataset& data) {
  const bool quiet = arguments.Flag("quiet");
  UnknownAssociationOptions options;
  options.tracks.gate_m = arguments.GetDouble("track-gate");
  options.tracks.max_pose_gap = static_cast<int>(arguments.GetInt("track-gap"));
  options.window_poses = static_cast<int>(arguments.GetInt("window"));
  options.free_poses = static_cast<int>(arguments.GetInt("free-poses"));
  options.targeted_radius_m = arguments.GetDouble("targeted-radius");
  options.targeted_max_candidates = static_cast<int>(arguments.GetInt("targeted-candidates"));
  options.min_track_sightings = static_cast<int>(arguments.GetInt("min-track"));
  options.sweep_radius_m = arguments.GetDouble("sweep-radius");
  options.diameter_per_track = arguments.Flag("diameter-per-track");
  options.joint_min_inliers = static_cast<int>(arguments.GetInt("joint-inliers"));
  options.joint_max_shift_m = arguments.GetDouble("joint-max-shift");
  options.hill_climb_steps_per_track = arguments.GetDouble("hill-climb");
  options.final_hill_climb_steps = static_cast<int>(arguments.GetInt("final-steps"));
  options.samples = static_cast<int>(arguments.GetInt("samples"));
  options.burn_in = options.samples / 10;
  options.num_chains = static_cast<int>(arguments.GetInt("chains"));
  options.seed = static_cast<unsigned long>(arguments.GetInt("seed"));
  options.moves.merge_distance_m = arguments.GetDouble("merge-distance");
  options.moves.merge_sigma_m = options.moves.merge_distance_m / 2;
  options.target.slam.initialisation_window_poses =
      static_cast<int>(arguments.GetInt("init-window"));
  options.target.slam.initialisation_gate = arguments.GetDouble("init-gate");
  options.target.slam.diameter_std_m = arguments.GetDouble("diameter-std");
  // A location prior is required to compare landmark counts: 100 m unless given.
  options.target.slam.landmark_prior_std_m =
      arguments.Has("landmark-prior-std") ? arguments.GetDouble("landmark-prior-std") : 100.0;
  const std::string mode = arguments.Get("evaluation");
  if (mode != "local" && mode != "exact" && mode != "marginal")
    throw UsageError("--evaluation must be marginal, local or exact, not '" + mode + "'");
  options.target.mode = mode == "exact"   ? LandmarkEvaluationMode::kExact
                        : mode == "local" ? LandmarkEvaluationMode::kLocal
                                          : LandmarkEvaluationMode::kMarginal;
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);

  const UnknownAssociationResult result =
      SolveUnknownAssociation(data, options, [&](const std::string& line) {
        if (!quiet) std::printf("%s\n", line.c_str());
        std::fflush(stdout);
      });
  const LandmarkSlamResult& solution = result.solution;
  const std::string output = arguments.Get("output");
  const std::string trajectory_path = OutputTrajectoryPath(arguments);
  OMapSource source{data.path,
                    "unknown (O-SLAM hill climbing" +
                        std::string(options.samples > 0 ? " + MC3" : "") + ", seed " +
                        arguments.Get("seed") + ")",
                    std::nullopt, std::nan(""), 0};
  WriteOMap(output, ToOMap(solution, arguments.Get("class"), source));
  WriteTextFileAtomically(trajectory_path, TrajectoryCsv(data, solution));
  if (arguments.Has("association-out")) {
    std::ostringstream out;  // the --association format: one id per sighting
    for (int id : result.association) out << id << '\n';
    WriteTextFileAtomically(arguments.Get("association-out"), out.str());
  }
  if (quiet) return solution.summary.IsUsable() ? 0 : 1;

  if (result.clutter_tracks > 0)
    std::printf("clutter: %ld tracks of fewer than %d sightings, %ld sightings, left out\n",
                result.clutter_tracks, options.min_track_sightings, result.clutter_sightings);
  if (result.scan_splits > 0)
    std::printf("%ld landmarks split where two merged tracks went on into one scan\n",
                result.scan_splits);
  std::printf(
      "%zu landmarks from %zu tracks of %d sightings; %ld proposals evaluated (%ld accepted, "
      "%ld full solves in the last window, %ld cold retries); "
      "hill climbing %.2f s (joint re-entry merges: %ld solves, %ld pairs kept, %.2f s), MC3 "
      "%.2f s, total %.2f s\n",
      solution.landmarks.size(), result.tracks.size(), solution.num_sightings_used,
      result.proposals, result.accepted, result.solves, result.cold_retries,
      result.hill_climb_time_s, result.joint_tries, result.joint_merges, result.joint_time_s,
      result.sampling_time_s, result.total_time_s);
  if (data.has_landmark_ids) {
    const std::vector<int> shipped = GivenAssociation(data);
    const PairwiseAgreement a = ComparePairwise(result.association, shipped);
    std::set<int> ids(shipped.begin(), shipped.end());
    ids.erase(-1);
    std::printf(
        "vs the file's ids: pairwise agreement %.5f, 'same landmark' pairs precision "
        "%.4f recall %.4f (%lld / %lld / %lld); landmarks %zu vs %zu\n",
        a.agreement, a.precision, a.recall, a.same_both, a.same_estimate, a.same_truth,
        solution.landmarks.size(), ids.size());
    LandmarkSlamOptions known_options = options.target.slam;
    known_options.compute_landmark_covariances = false;
    LandmarkSlam known(known_options);
    const LandmarkSlamResult reference = known.Solve(data, shipped);
    std::printf(
        "trajectory vs the shipped-association solve: RMSE %.3f m (its log evidence "
        "%.1f, ours %.1f)\n",
        TrajectoryRmse(solution.trajectory, reference.trajectory), reference.evidence.log_evidence,
        result.log_target);
  }
  PrintGpsError(arguments, data, solution.trajectory);
  std::printf("wrote %s and %s\n", output.c_str(), trajectory_path.c_str());
  return solution.summary.IsUsable() ? 0 : 1;
}

}  // namespace

int RunLandmarkMapCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam map --landmarks FILE [--format gtsam|victoria-raw] -o OMAP.json [options]",
      "Landmark SLAM on a range-bearing data set (docs/formats.md, Landmark data sets) with "
      "the association its landmark ids (or --association) give; writes the O-Map (one 'tree' "
      "object per "
      "landmark) and the trajectory CSV.");
  arguments.AddOption("landmarks", "", "FILE",
                      "gtsam: the text file; victoria-raw: measurements.dat or its folder");
  arguments.AddOption("format", "", "NAME", "gtsam or victoria-raw", "gtsam");
  arguments.AddOption("inputs", "", "FILE",
                      "victoria-raw: speed/steering file (default: inputs.dat beside FILE)");
  arguments.AddOption("association", "", "FILE",
                      "one landmark id per sighting (-1: leave out) instead of the file's ids");
  arguments.AddOption("output", "-o", "OMAP.json", "where to write the O-Map (atomically)");
  arguments.AddOption("association-out", "", "FILE",
                      "unknown association: write the landmark id of every sighting (-1: "
                      "clutter), in the --association format");
  arguments.AddOption("trajectory", "", "CSV",
                      "where to write the trajectory (default: trajectory.csv beside the O-Map)");
  arguments.AddOption("class", "", "NAME", "class name of the landmarks in the O-Map", "tree");
  arguments.AddOption("init-gate", "", "CHI2",
                      "staged initialisation: solve the poses so far wherever a sighting or "
                      "loop closure is off its prediction by more than this squared whitened "
                      "error (0: off)",
                      "100");
  arguments.AddOption("init-window", "", "POSES",
                      "staged initialisation: fixed stages of this many poses, or with the gate "
                      "the longest stage (0: none; both 0: start from dead reckoning)",
                      "0");
  arguments.AddOption("landmark-prior-std", "", "M",
                      "std of a zero-mean location prior on every landmark (0: none; makes the "
                      "evidence comparable across associations)",
                      "0");
  arguments.AddOption("diameter-std", "", "M",
                      "std of one trunk-diameter measurement (where the data set has them)",
                      "0.05");
  arguments.AddFlag("pose-covariances", "also compute every pose's covariance (slower)");
  arguments.AddFlag("unknown-association",
                    "ignore the file's landmark ids: tracks, O-SLAM hill climbing in growing "
                    "windows, optional MC3; compared with the ids when the file has them");
  arguments.AddOption("seed", "", "N", "unknown association: random seed", "1");
  arguments.AddOption("hill-climb", "", "STEPS",
                      "unknown association: hill-climbing steps per track of each window", "4");
  arguments.AddOption("final-steps", "", "STEPS",
                      "unknown association: global hill-climbing steps after the windows", "0");
  arguments.AddOption("samples", "", "N", "unknown association: MC3 iterations (0: none)", "0");
  arguments.AddOption("chains", "", "N", "unknown association: MC3 chains", "2");
  arguments.AddOption("window", "", "POSES",
                      "unknown association: poses added per hill-climbing window (0: one window)",
                      "20");
  arguments.AddOption("track-gate", "", "M",
                      "unknown association: a sighting continues a track when its world position "
                      "is this close to the track's last one",
                      "1.0");
  arguments.AddOption("track-gap", "", "POSES",
                      "unknown association: at most this many poses between a track's sightings",
                      "20");
  arguments.AddOption("merge-distance", "", "M",
                      "unknown association: landmarks closer than this are merge candidates",
                      "3.0");
  arguments.AddOption("targeted-radius", "", "M",
                      "unknown association: score each new landmark's merge with every landmark "
                      "this close first (marginal evaluation; 0: off)",
                      "50");
  arguments.AddOption("targeted-candidates", "", "N",
                      "unknown association: at most the N nearest landmarks per targeted merge "
                      "(0: all within the radius)",
                      "0");
  arguments.AddFlag("diameter-per-track",
                    "unknown association: a track measures its trunk diameter once (its mean) "
                    "rather than once per sighting");
  arguments.AddOption("sweep-radius", "", "M",
                      "unknown association: after each window, score merging every pair of "
                      "landmarks this close (0: off)",
                      "0");
  arguments.AddOption("min-track", "", "N",
                      "unknown association: tracks with fewer sightings are clutter, left out "
                      "(1: none)",
                      "1");
  arguments.AddOption("joint-inliers", "", "N",
                      "unknown association: joint re-entry merges (RANSAC alignment of the recent "
                      "landmarks onto old ones) need this many aligned pairs (0: off)",
                      "8");
  arguments.AddOption("joint-max-shift", "", "M",
                      "unknown association: joint merges only for alignments shifting the "
                      "recent landmarks at most this far (0: no limit)",
                      "0");
  arguments.AddOption("free-poses", "", "POSES",
                      "unknown association: poses free in a window's solves, earlier ones held "
                      "(0: all free)",
                      "0");
  arguments.AddOption("poses", "", "N",
                      "use only the first N poses of the data set (0: all), e.g. to time subsets",
                      "0");
  arguments.AddOption("odometry-noise-scale", "", "K",
                      "multiply every odometry covariance by K (a model choice)", "1");
  arguments.AddOption("evaluation", "", "MODE",
                      "unknown association: marginal (merges in closed form from the joint "
                      "marginal covariance), local (poses held) or exact (whole re-solve)",
                      "marginal");
  arguments.AddOption(
      "gps", "", "FILE",
      "compare the trajectory with GPS fixes (gps.dat: time x y; needs pose times)");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("landmarks")) throw UsageError("give the data set with --landmarks FILE");
  if (!arguments.Has("output")) throw UsageError("give the output file with -o OMAP.json");
  const std::string format = arguments.Get("format");
  if (format != "gtsam" && format != "victoria-raw")
    throw UsageError("--format must be gtsam or victoria-raw, not '" + format + "'");
  if (arguments.GetInt("init-window") < 0) throw UsageError("--init-window must be >= 0");

  const std::string file = arguments.Get("landmarks");
  LandmarkDataset data;
  if (format == "gtsam") {
    data = ReadGtsamLandmarks(file);
  } else {
    namespace fs = std::filesystem;
    const fs::path measurements =
        fs::is_directory(file) ? fs::path(file) / "measurements.dat" : fs::path(file);
    const std::string inputs = arguments.Has("inputs")
                                   ? arguments.Get("inputs")
                                   : (measurements.parent_path() / "inputs.dat").string();
    data = ReadVictoriaRaw(measurements.string(), inputs);
  }
  const long poses = arguments.GetInt("poses");
  if (poses < 0) throw UsageError("--poses must be >= 0");
  if (poses > 0 && poses < data.num_poses) data = PosePrefix(data, static_cast<int>(poses));
  const double odometry_scale = arguments.GetDouble("odometry-noise-scale");
  if (!(odometry_scale > 0) || !std::isfinite(odometry_scale))
    throw UsageError("--odometry-noise-scale must be > 0");
  for (RelativePoseMeasurement& edge : data.odometry) edge.covariance *= odometry_scale;
  if (arguments.Flag("unknown-association")) return RunUnknownAssociation(arguments, data);
  std::vector<int> association;
  std::string association_source = "known (landmark ids in the file)";
  if (arguments.Has("association")) {
    association = ReadAssociation(arguments.Get("association"), data.sightings.size());
    association_source = "given (" + arguments.Get("association") + ")";
  } else if (data.has_landmark_ids) {
    association = GivenAssociation(data);
  } else {
    throw Error::InFile(data.path,
                        "the sightings have no landmark ids; give them with --association FILE "
                        "or solve with --unknown-association");
  }

  LandmarkSlamOptions options;
  options.initialisation_window_poses = static_cast<int>(arguments.GetInt("init-window"));
  options.initialisation_gate = arguments.GetDouble("init-gate");
  options.compute_pose_covariances = arguments.Flag("pose-covariances");
  options.landmark_prior_std_m = arguments.GetDouble("landmark-prior-std");
  options.diameter_std_m = arguments.GetDouble("diameter-std");
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);
  LandmarkSlam slam(options);
  const LandmarkSlamResult result = slam.Solve(data, association);

  const std::string output = arguments.Get("output");
  const std::string trajectory_path =
      arguments.Has("trajectory")
          ? arguments.Get("trajectory")
          : (std::filesystem::path(output).parent_path() / "trajectory.csv").string();
  OMapSource source{data.path, association_source, std::nullopt, std::nan(""), 0};
  WriteOMap(output, ToOMap(result, arguments.Get("class"), source));
  WriteTextFileAtomically(trajectory_path, TrajectoryCsv(data, result));

  if (!arguments.Flag("quiet")) {
    const SolverSummary& s = result.summary;
    std::printf("%zu landmarks from %d sightings, %d poses (%s format)\n", result.landmarks.size(),
                result.num_sightings_used, data.num_poses, format.c_str());
    std::printf(
        "solver: %s (%s), %d iterations, cost %.6g -> %.6g (chi2 per residual %.3f), "
        "%.1f ms\n",
        TerminationName(s.termination), s.message.c_str(), s.iterations, s.initial_cost,
        s.final_cost, s.num_residuals > 0 ? 2.0 * s.final_cost / s.num_residuals : 0.0,
        1e3 * s.total_time_s);
    std::printf("total %.1f ms (staged initialisation %.1f ms, %d stages)\n",
                1e3 * result.total_time_s, 1e3 * result.initialisation_time_s,
                result.initialisation_stages);
    if (result.evidence.valid) std::printf("log evidence %.3f\n", result.evidence.log_evidence);
    std::printf("trajectory %.1f m (dead reckoning %.1f m)\n", TrajectoryLength(result.trajectory),
                TrajectoryLength(data.dead_reckoning));
    std::printf("wrote %s and %s\n", output.c_str(), trajectory_path.c_str());
  }
  return result.summary.IsUsable() ? 0 : 1;
}

}  // namespace oslam
