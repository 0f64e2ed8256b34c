// oslam map --landmarks FILE: planar landmark SLAM on a range-bearing data
// set, the association taken from the file's landmark ids (GTSAM format) or
// from an association file, or found (--unknown-association). Writes the
// O-Map (trees as objects) and the trajectory CSV.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>

#include "apps/map_modes.h"
#include "association/association_metrics.h"
#include "association/landmark_tracks.h"
#include "core/atomic_file.h"
#include "core/csv.h"
#include "core/error.h"
#include "core/text.h"
#include "omap/omap_json.h"
#include "slam/landmark_formats.h"
#include "slam/landmark_noise.h"
#include "slam/landmark_reference.h"
#include "slam/slam_omap.h"
#include "solver/summary_report.h"

namespace oslam {
namespace {

std::string TrajectoryCsv(const LandmarkDataset& data, const LandmarkSlamResult& result) {
  std::ostringstream out;
  const bool times = static_cast<int>(data.pose_times.size()) == data.num_poses;
  // --pose-covariances: each pose's marginal standard deviations as well.
  const bool spread = static_cast<int>(result.pose_covariances.size()) == data.num_poses;
  out << "pose,pose_id," << (times ? "time_s," : "") << "x_m,y_m,theta_rad"
      << (spread ? ",x_std_m,y_std_m,theta_std_rad" : "") << '\n';
  for (int i = 0; i < data.num_poses; ++i) {
    const Pose2& p = result.trajectory[i];
    out << i << ',' << data.pose_ids[i] << ',';
    if (times) out << CsvNumber(data.pose_times[i]) << ',';
    out << CsvNumber(p.x) << ',' << CsvNumber(p.y) << ',' << CsvNumber(p.theta);
    if (spread)
      for (int k = 0; k < 3; ++k)
        out << ',' << CsvNumber(std::sqrt(std::max(0.0, result.pose_covariances[i](k, k))));
    out << '\n';
  }
  return out.str();
}

// --gps-antenna: "estimate", or the mount as "FORWARD,LEFT" (metres, robot
// frame).
GpsComparisonOptions GpsAntennaOptions(const std::string& value) {
  GpsComparisonOptions options;
  if (value == "estimate") {
    options.estimate_antenna_offset = true;
    return options;
  }
  const size_t comma = value.find(',');
  const std::string parts[2] = {value.substr(0, comma),
                                comma == std::string::npos ? "" : value.substr(comma + 1)};
  for (int k = 0; k < 2; ++k) {
    char* end = nullptr;
    options.antenna_offset_m[k] = std::strtod(parts[k].c_str(), &end);
    if (parts[k].empty() || *end != '\0' || !std::isfinite(options.antenna_offset_m[k])) break;
    if (k == 1) return options;
  }
  throw UsageError("--gps-antenna: '" + value +
                   "' is neither 'estimate' nor FORWARD,LEFT in metres (e.g. 3.78,0.5)");
}

void PrintGpsError(const std::string& gps_path, const std::string& antenna,
                   const LandmarkDataset& data, const std::vector<Pose2>& trajectory) {
  if (gps_path.empty()) return;
  if (static_cast<int>(data.pose_times.size()) != data.num_poses)
    throw Error::InFile(data.path, "--gps needs pose times, which this format has not");
  const std::vector<GpsFix> gps = ReadGps(gps_path);
  const GpsComparisonOptions options = GpsAntennaOptions(antenna);
  const GpsError e = CompareWithGps(trajectory, data.pose_times, gps, options);
  // The dead reckoning is compared at the same antenna position.
  GpsComparisonOptions same_antenna;
  same_antenna.antenna_offset_m = e.antenna_offset_m;
  const GpsError d = CompareWithGps(data.dead_reckoning, data.pose_times, gps, same_antenna);
  const GpsError origin = CompareWithGps(trajectory, data.pose_times, gps);
  std::printf(
      "vs GPS (%d fixes, rigid alignment, antenna %.2f m forward, %.2f m left%s): RMSE %.2f m, "
      "median %.2f m, max %.2f m (dead reckoning: RMSE %.2f m, median %.2f m, max %.2f m; the "
      "robot origin against the fixes: RMSE %.2f m)\n",
      e.num_fixes, e.antenna_offset_m.x(), e.antenna_offset_m.y(),
      options.estimate_antenna_offset ? ", estimated" : "", e.rmse_m, e.median_m, e.max_m, d.rmse_m,
      d.median_m, d.max_m, origin.rmse_m);
}

// A true trajectory (oslam simulate-landmarks' true_trajectory.csv: pose,
// x_m, y_m, theta_rad), one row per pose of the data set.
std::vector<Pose2> ReadTrueTrajectory(const std::string& path, int num_poses) {
  const CsvTable table = CsvTable::Read(path);
  if (static_cast<int>(table.num_rows()) != num_poses)
    throw Error::InFile(path, std::to_string(table.num_rows()) + " poses for a data set of " +
                                  std::to_string(num_poses));
  const int x = table.ColumnIndex("x_m"), y = table.ColumnIndex("y_m"),
            theta = table.ColumnIndex("theta_rad");
  std::vector<Pose2> poses;
  for (size_t i = 0; i < table.num_rows(); ++i)
    poses.push_back({table.Double(i, x), table.Double(i, y), table.Double(i, theta)});
  return poses;
}

// The O-Map and the trajectory CSV (default: trajectory.csv beside the
// O-Map); returns the trajectory's path.
std::string WriteMapAndTrajectory(const std::string& output, std::string trajectory_path,
                                  const LandmarkDataset& data, const LandmarkSlamResult& result,
                                  const std::string& class_name, const std::string& association) {
  // A failed solve is no map: say so, naming the data set, and write nothing.
  if (!result.summary.IsUsable())
    throw Error::InFile(data.path, "the solver failed on this data set (" + result.summary.message +
                                       "); no map written");
  if (trajectory_path.empty())
    trajectory_path = (std::filesystem::path(output).parent_path() / "trajectory.csv").string();
  const OMapSource source{data.path, association, std::nullopt, std::nan(""), 0};
  WriteOMap(output, ToOMap(result, class_name, source));
  WriteTextFileAtomically(trajectory_path, TrajectoryCsv(data, result));
  return trajectory_path;
}

// The file's sightings (the format detected unless given), odometry scaled
// and cut to the first poses asked for.
LandmarkDataset ReadDataset(const std::string& file, std::string* format,
                            const std::string& inputs_path, long poses, double odometry_scale,
                            bool quiet) {
  LandmarkFormat chosen;
  if (*format == "auto") {
    const DetectedLandmarkFormat detected = DetectLandmarkFormat(file);
    chosen = detected.format;
    *format = LandmarkFormatName(chosen);
    if (!quiet) std::printf("format %s: %s\n", format->c_str(), detected.reason.c_str());
  } else {
    chosen = *LandmarkFormatFromName(*format);
  }
  LandmarkReadOptions read;
  read.inputs_path = inputs_path;
  LandmarkDataset data = ReadLandmarkDataset(file, chosen, read);
  if (poses > 0 && poses < data.num_poses) data = PosePrefix(data, static_cast<int>(poses));
  for (RelativePoseMeasurement& edge : data.odometry) edge.covariance *= odometry_scale;
  return data;
}

// Named sets of the flags below for data sets that need more than the
// defaults; flags given on the command line override them.
struct LandmarkPreset {
  const char* name;
  const char* help;
  std::vector<std::pair<const char*, const char*>> flags;
};

const std::vector<LandmarkPreset>& LandmarkPresets() {
  static const std::vector<LandmarkPreset> presets = {
      {"victoria-raw",
       "Victoria Park's raw laser scans (measurements.dat): ids unknown, most short tracks "
       "clutter, a trunk diameter per track, 50-pose windows with few candidates per landmark, "
       "re-entries closed by the joint merges within 30 m (no screen of 4-pair alignments among "
       "the clutter)",
       {{"format", "victoria-raw"},
        {"unknown-association", "1"},
        {"min-track", "3"},
        {"diameter-per-track", "1"},
        {"diameter-std", "0.06"},
        {"window", "50"},
        {"hill-climb", "1"},
        {"targeted-radius", "20"},
        {"targeted-candidates", "10"},
        {"sweep-radius", "1.5"},
        {"joint-max-shift", "30"},
        {"joint-screen", "0"}}},
  };
  return presets;
}

std::string PresetHelp() {
  std::string help = "set the flags of a named data set kind (flags given override them):";
  for (const LandmarkPreset& p : LandmarkPresets()) {
    help += std::string(" ") + p.name + " (" + p.help + ":";
    for (const auto& [flag, value] : p.flags)
      help +=
          std::string(" --") + flag + (std::string(value) == "1" ? "" : std::string(" ") + value);
    help += ")";
  }
  return help;
}

}  // namespace

void LandmarkMode::ApplyPreset(const std::string& name) {
  for (const LandmarkPreset& p : LandmarkPresets()) {
    if (name != p.name) continue;
    for (const auto& [flag, value] : p.flags) {
      const Binding* binding = bindings_.FindFlag(flag);
      if (!binding) throw Error(std::string("preset ") + p.name + ": no flag --" + flag);
      const std::string problem = binding->Set(value);
      if (!problem.empty()) throw Error(std::string("preset ") + p.name + ": --" + flag + problem);
    }
    return;
  }
  std::string names;
  for (const LandmarkPreset& p : LandmarkPresets()) names += std::string(" ") + p.name;
  throw UsageError("--preset: unknown preset '" + name + "' (known:" + names + ")");
}

void LandmarkMode::Declare(Arguments* arguments) {
  Options& o = options_;
  UnknownAssociationOptions& u = o.unknown;
  Bindings& b = bindings_;
  arguments->AddOption("preset", "", "NAME", PresetHelp());
  arguments->AddOption("landmarks", "", "FILE",
                       "the data set: a text file (gtsam, g2o, toro, isam), or victoria-raw's "
                       "measurements.dat or its folder");
  b.AddChoice<std::string>(&o.format,
                           {{"auto", "auto"},
                            {"gtsam", "gtsam"},
                            {"g2o", "g2o"},
                            {"toro", "toro"},
                            {"isam", "isam"},
                            {"victoria-raw", "victoria-raw"}},
                           "format", "NAME",
                           "auto (from the file's records), gtsam, g2o, toro, isam or victoria-raw "
                           "(docs/formats.md)");
  b.Add(&o.inputs, "inputs", "FILE",
        "victoria-raw: speed/steering file (default: inputs.dat beside FILE)");
  b.Add(&o.association, "association", "FILE",
        "one landmark id per sighting (-1: leave out) instead of the file's ids");
  b.Add(&o.association_out, "association-out", "FILE",
        "unknown association: write the landmark id of every sighting (-1: clutter), in the "
        "--association format");
  b.Add(&o.trajectory, "trajectory", "CSV",
        "where to write the trajectory (default: trajectory.csv beside the O-Map)");
  b.Add(&o.class_name, "class", "NAME", "class name of the landmarks in the O-Map");
  b.Add(&o.slam.initialisation_gate, "init-gate", "CHI2",
        "staged start: solve the poses so far wherever a sighting or loop closure is off its "
        "prediction by more than this (squared errors, noise floored; 0: off)")
      .Check([this] { return options_.slam.initialisation_gate >= 0; }, "must be >= 0");
  b.Add(&o.slam.initialisation_window_poses, "init-window", "POSES",
        "staged start: fixed stages of this many poses, with the gate the longest stage (0: "
        "none; both 0: start from dead reckoning)")
      .Check([this] { return options_.slam.initialisation_window_poses >= 0; }, "must be >= 0");
  b.Add(&o.slam.landmark_prior_std_m, "landmark-prior-std", "M",
        "std of a Gaussian location prior on every landmark (0: none; makes the evidence "
        "comparable across associations, but pulls the landmarks toward its mean)")
      .Check([this] { return options_.slam.landmark_prior_std_m >= 0; }, "must be >= 0");
  b.AddCustom(
       "landmark-density", "PER_M2|auto",
       "location prior of constant density on every landmark, landmarks per square metre "
       "(0: none; makes the evidence comparable across associations without moving "
       "anything; auto: sightings per scan over the area a scan sees, docs/method.md §16.2; "
       "the default with --unknown-association: 1.59e-5)",
       [this] {
         return options_.unknown.landmark_density_from_data
                    ? std::string("auto")
                    : Format("%g", options_.slam.landmark_density_per_m2);
       },
       [this](const std::string& text) -> std::string {
         options_.unknown.landmark_density_from_data = text == "auto";
         if (text == "auto") return "";
         return ParseNumber(text, false, &options_.slam.landmark_density_per_m2);
       })
      .Check([this] { return options_.slam.landmark_density_per_m2 >= 0; }, "must be >= 0");
  b.Add(&o.slam.diameter_std_m, "diameter-std", "M",
        "std of one trunk-diameter measurement (where the data set has them)");
  b.AddFlag(&o.slam.compute_pose_covariances, "pose-covariances",
            "also compute every pose's covariance (slower)");
  b.AddFlag(&o.calibrate_noise, "calibrate-noise",
            "known association: estimate the variance components of the sightings' and the "
            "odometry's noise at the association and solve under them (docs/method.md §16.3)");
  b.AddFlag(&o.unknown_association, "unknown-association",
            "ignore the file's landmark ids: tracks, O-SLAM hill climbing in growing windows, "
            "optional MC3; compared with the ids when the file has them");
  b.Add(&u.seed, "seed", "N", "unknown association: random seed");
  b.Add(&u.hill_climb_steps_per_track, "hill-climb", "STEPS",
        "unknown association: hill-climbing steps per track of each window");
  b.Add(&u.final_hill_climb_steps, "final-steps", "STEPS",
        "unknown association: global hill-climbing steps after the windows");
  b.Add(&u.samples, "samples", "N", "unknown association: MC3 iterations (0: none)");
  b.Add(&u.num_chains, "chains", "N", "unknown association: MC3 chains");
  b.Add(&u.window_poses, "window", "POSES",
        "unknown association: poses added per hill-climbing window (0: one window)");
  b.Add(&u.window_drift_spacing, "window-drift", "FRACTION",
        "unknown association: a window also ends where the dead reckoning's drift since the "
        "last solve reaches this fraction of the landmarks' spacing (0: off)")
      .Check([this] { return options_.unknown.window_drift_spacing >= 0; }, "must be >= 0");
  b.Add(&u.tracks.gate_m, "track-gate", "M",
        "unknown association: a sighting continues a track when its world position is this "
        "close to the track's last one");
  b.Add(&u.tracks.max_pose_gap, "track-gap", "POSES",
        "unknown association: at most this many poses between a track's sightings");
  b.Add(&u.moves.merge_distance_m, "merge-distance", "M",
        "unknown association: landmarks closer than this are merge candidates");
  b.Add(&u.targeted_radius_m, "targeted-radius", "M",
        "unknown association: score each new landmark's merge with every landmark this close "
        "first (marginal evaluation; 0: off)");
  b.Add(&u.targeted_max_candidates, "targeted-candidates", "N",
        "unknown association: at most the N nearest landmarks per targeted merge (0: all "
        "within the radius)");
  b.AddFlag(&u.diameter_per_track, "diameter-per-track",
            "unknown association: a track measures its trunk diameter once (its mean) rather "
            "than once per sighting");
  b.Add(&u.sweep_radius_m, "sweep-radius", "M",
        "unknown association: after each window, score merging every pair of landmarks this "
        "close (0: off)");
  b.Add(&u.min_track_sightings, "min-track", "N",
        "unknown association: tracks with fewer sightings are clutter, left out (1: none)");
  b.Add(&u.joint_min_inliers, "joint-inliers", "N",
        "unknown association: joint re-entry merges (RANSAC alignment of the recent landmarks "
        "onto old ones) need this many aligned pairs (0: off)");
  b.Add(&u.joint_recent_m, "joint-recent", "M",
        "unknown association: joint merges align the landmarks first seen in the last M metres "
        "driven onto older ones");
  b.Add(&u.threads, "threads", "N",
        "threads linearising large problems and, with unknown association, measuring the joint "
        "merges' RANSAC samples (0: one per core; the same result for any N)")
      .Check([this] { return options_.unknown.threads >= 0; }, "must be >= 0");
  b.Add(&u.joint_repair_rounds, "joint-repair", "ROUNDS",
        "unknown association: after a joint merge's solve, split off the worst-fitting pairs and "
        "re-solve, at most this many times (0: never)");
  b.Add(&u.targeted_repair_rounds, "targeted-repair", "ROUNDS",
        "unknown association: when a batch of targeted merges lowers the evidence, undo its "
        "misfit merges and re-solve, at most this many times, before keeping only the best "
        "merge (0: at once)")
      .Check([this] { return options_.unknown.targeted_repair_rounds >= 0; }, "must be >= 0");
  b.Add(&u.probation_windows, "probation-windows", "N",
        "unknown association: a loop closure by targeted merges that gains little but moves a "
        "pose far is decided N windows later, by running its windows again without it and "
        "keeping the path with the higher evidence (0: off)")
      .Check([this] { return options_.unknown.probation_windows >= 0; }, "must be >= 0");
  b.Add(&u.probation_max_gain, "probation-gain", "NATS",
        "unknown association: loop closures gaining less than this go on probation")
      .Check([this] { return options_.unknown.probation_max_gain >= 0; }, "must be >= 0");
  b.Add(&u.probation_shift_spacing, "probation-shift", "SPACINGS",
        "unknown association: ... and moving a pose by more than this many landmark spacings")
      .Check([this] { return options_.unknown.probation_shift_spacing >= 0; }, "must be >= 0");
  b.Add(&u.joint_max_shift_m, "joint-max-shift", "M",
        "unknown association: joint merges only for alignments shifting the recent landmarks "
        "at most this far (0: no limit)");
  b.AddChoice<bool>(&u.joint_loop_anchor, {{"on", true}, {"off", false}}, "joint-loop-anchor",
                    "on|off",
                    "unknown association: joint merges also try the correction spread along the "
                    "whole loop, from where its old landmarks were last seen");
  b.Add(&u.joint_screen_candidates, "joint-screen", "N",
        "unknown association: re-entries below the joint merges' floors: the N best alignments "
        "of at least 4 pairs judged by the closed-form evidence of merging their pairs at once "
        "(0: off)");
  b.AddChoice<bool>(&u.calibrate_on_tracks, {{"on", true}, {"off", false}}, "calibrate-tracks",
                    "on|off",
                    "unknown association: estimate the noise's variance components with every "
                    "track its own landmark before the search, and search under that noise");
  b.Add(&u.calibration_rounds, "calibration-rounds", "N",
        "unknown association: after the search, re-estimate the noise at the association found "
        "and refine it by split and merge sweeps, N times (0: none)");
  b.Add(&u.sighting_split_gate, "sighting-split-gate", "CHI2",
        "unknown association: after the final solve, split a sighting off its track when its "
        "squared whitened error exceeds this and the evidence rises (0: off)");
  b.Add(&u.free_poses, "free-poses", "POSES",
        "unknown association: poses free in a window's solves, earlier ones held (0: all free)");
  b.Add(&o.poses, "poses", "N",
        "use only the first N poses of the data set (0: all), e.g. to time subsets")
      .Check([this] { return options_.poses >= 0; }, "must be >= 0");
  b.Add(&o.odometry_noise_scale, "odometry-noise-scale", "K",
        "multiply every odometry covariance by K (a model choice)")
      .Check([this] { return options_.odometry_noise_scale > 0; }, "must be > 0");
  b.AddChoice(&u.target.mode,
              {{"marginal", LandmarkEvaluationMode::kMarginal},
               {"local", LandmarkEvaluationMode::kLocal},
               {"exact", LandmarkEvaluationMode::kExact}},
              "evaluation", "MODE",
              "unknown association: marginal (merges in closed form from the joint marginal "
              "covariance), local (poses held) or exact (whole re-solve)");
  b.Add(&o.truth_trajectory, "truth-trajectory", "CSV",
        "print the trajectory's RMSE against this true one (pose,x_m,y_m,theta_rad; the data "
        "set's frame, e.g. from oslam simulate-landmarks)");
  b.Add(&o.gps, "gps", "FILE",
        "compare the trajectory with GPS fixes (gps.dat: time x y; needs pose times)");
  b.Add(&o.gps_antenna, "gps-antenna", "FORWARD,LEFT",
        "where the GPS antenna sits in the robot frame, metres, or 'estimate' (fitted with the "
        "alignment)");
  b.Declare(arguments);
}

int LandmarkMode::Run(const Arguments& arguments) {
  if (!arguments.Has("output")) throw UsageError("give the output file with -o OMAP.json");
  if (arguments.Has("preset")) ApplyPreset(arguments.Get("preset"));
  bindings_.Apply(arguments);
  Options& o = options_;
  GpsAntennaOptions(o.gps_antenna);  // a bad value fails before the solve
  const LandmarkDataset data = ReadDataset(arguments.Get("landmarks"), &o.format, o.inputs, o.poses,
                                           o.odometry_noise_scale, arguments.Flag("quiet"));
  if (o.unknown_association) return RunUnknownAssociation(arguments, data);
  std::vector<int> association;
  std::string association_source = "known (landmark ids in the file)";
  if (!o.association.empty()) {
    association = ReadAssociation(o.association, data.sightings.size());
    association_source = "given (" + o.association + ")";
  } else if (data.has_landmark_ids) {
    association = GivenAssociation(data);
  } else {
    throw Error::InFile(data.path,
                        "the sightings have no landmark ids; give them with --association FILE "
                        "or solve with --unknown-association");
  }
  o.slam.solver.threads = o.unknown.threads;  // --threads
  if (o.unknown.landmark_density_from_data) {
    o.slam.landmark_density_per_m2 = SightingDensityPerM2(data);
    if (!arguments.Flag("quiet"))
      std::printf("landmark density from the sightings: %.3g per m2\n",
                  o.slam.landmark_density_per_m2);
  }
  std::string why;
  if (!o.slam.Validate(&why)) throw UsageError(why);
  LandmarkSlamResult result;
  if (o.calibrate_noise) {
    NoiseCalibrationResult c = CalibrateNoise(data, association, o.slam, NoiseCalibrationOptions());
    const NoiseScales& n = c.scales;
    if (!arguments.Flag("quiet"))
      std::printf(
          "noise calibration: the stated variances times %.3g (range), %.3g (bearing), %.3g "
          "(point), %.3g (odometry translation), %.3g (heading); %d outliers left out, %.2f s\n",
          n.range, n.bearing, n.point, n.odometry_translation, n.odometry_heading, c.outliers,
          c.time_s);
    result = std::move(c.solution);
  } else {
    LandmarkSlam slam(o.slam);
    result = slam.Solve(data, association);
  }
  const std::string output = arguments.Get("output");
  const std::string trajectory_path =
      WriteMapAndTrajectory(output, o.trajectory, data, result, o.class_name, association_source);

  if (!arguments.Flag("quiet")) {
    const SolverSummary& s = result.summary;
    std::printf("%zu landmarks from %d sightings, %d poses (%s format)\n", result.landmarks.size(),
                result.num_sightings_used, data.num_poses, o.format.c_str());
    std::printf("solver: %s (chi2 per residual %.3f), %.1f ms\n", BriefReport(s).c_str(),
                s.num_residuals > 0 ? 2.0 * s.final_cost / s.num_residuals : 0.0,
                1e3 * s.total_time_s);
    std::printf("total %.1f ms (staged initialisation %.1f ms, %d stages)\n",
                1e3 * result.total_time_s, 1e3 * result.initialisation_time_s,
                result.initialisation_stages);
    if (result.evidence.valid) std::printf("log evidence %.3f\n", result.evidence.log_evidence);
    std::printf("trajectory %.1f m (dead reckoning %.1f m)\n", TrajectoryLength(result.trajectory),
                TrajectoryLength(data.dead_reckoning));
    if (!o.truth_trajectory.empty()) {
      const std::vector<Pose2> truth = ReadTrueTrajectory(o.truth_trajectory, data.num_poses);
      std::printf("vs the true trajectory: RMSE %.3f m; after a rigid alignment (ATE) %.3f m\n",
                  TrajectoryRmse(result.trajectory, truth),
                  AlignedTrajectoryRmse(result.trajectory, truth));
    }
    std::printf("wrote %s and %s\n", output.c_str(), trajectory_path.c_str());
  }
  PrintGpsError(o.gps, o.gps_antenna, data, result.trajectory);
  return 0;
}

namespace {

// The association found against the file's ids: as shipped, with the
// file's duplicate landmarks joined, and with the sightings the file's own
// solve cannot explain left out too (slam/landmark_reference.h); the
// trajectory against the file's association solved under the same noise,
// with and without those sightings.
void PrintAgainstFileIds(const LandmarkDataset& data, const UnknownAssociationOptions& options,
                         const UnknownAssociationResult& result,
                         const std::string& truth_trajectory) {
  const std::vector<int> shipped = GivenAssociation(data);
  std::set<int> ids(shipped.begin(), shipped.end());
  ids.erase(-1);
  const LandmarkDataset noise = WithNoiseScales(data, result.noise_scales);
  const LandmarkSlamOptions& known_options = result.slam_options;  // the search's model
  const LandmarkSlamResult reference = LandmarkSlam(known_options).Solve(noise, shipped);
  int joined = 0, outliers = 0;
  const std::vector<int> fixed = JoinDuplicateLandmarks(data, shipped, reference, 0.25, &joined);
  LandmarkSlamResult clean;
  const std::vector<int> inliers = LeaveOutOutlierSightings(
      noise, fixed, known_options, options.calibration.outlier_gate, &clean, &outliers);
  std::vector<int> found = result.association;  // the same sightings left out of ours
  for (size_t k = 0; k < found.size(); ++k)
    if (inliers[k] < 0) found[k] = -1;
  const PairwiseAgreement a = ComparePairwise(result.association, shipped);
  const PairwiseAgreement b = ComparePairwise(result.association, fixed);
  const PairwiseAgreement c = ComparePairwise(found, inliers);
  const std::set<int> kept(fixed.begin(), fixed.end());
  std::printf(
      "vs the file's ids: pairwise agreement %.5f, 'same landmark' pairs precision "
      "%.4f recall %.4f (%lld / %lld / %lld); landmarks %zu vs %zu\n",
      a.agreement, a.precision, a.recall, a.same_both, a.same_estimate, a.same_truth,
      result.solution.landmarks.size(), ids.size());
  std::printf(
      "vs the file's ids with its %d duplicate landmarks joined (%zu landmarks): precision "
      "%.4f recall %.4f; also without the %d sightings its own solve leaves beyond the "
      "outlier gate: precision %.4f recall %.4f\n",
      joined, kept.size() - kept.count(-1), b.precision, b.recall, outliers, c.precision, c.recall);
  std::printf(
      "trajectory vs the file's association solved under the same noise: RMSE %.3f m (its "
      "log evidence %.1f, ours %.1f); without its outlier sightings %.3f m\n",
      TrajectoryRmse(result.solution.trajectory, reference.trajectory),
      reference.evidence.log_evidence, result.log_target,
      TrajectoryRmse(result.solution.trajectory, clean.trajectory));
  if (!truth_trajectory.empty()) {
    const std::vector<Pose2> truth = ReadTrueTrajectory(truth_trajectory, data.num_poses);
    std::printf(
        "vs the true trajectory: RMSE %.3f m (the file's association's %.3f m); after a rigid "
        "alignment (ATE) %.3f m (%.3f m)\n",
        TrajectoryRmse(result.solution.trajectory, truth),
        TrajectoryRmse(reference.trajectory, truth),
        AlignedTrajectoryRmse(result.solution.trajectory, truth),
        AlignedTrajectoryRmse(reference.trajectory, truth));
  }
}

}  // namespace

// --unknown-association: the file's ids are hidden from the solve and used
// only to score it.
int LandmarkMode::RunUnknownAssociation(const Arguments& arguments, const LandmarkDataset& data) {
  const bool quiet = arguments.Flag("quiet");
  UnknownAssociationOptions options = options_.unknown;
  options.burn_in = options.samples / 10;
  options.moves.merge_sigma_m = options.moves.merge_distance_m / 2;
  options.target.slam.initialisation_window_poses = options_.slam.initialisation_window_poses;
  options.target.slam.initialisation_gate = options_.slam.initialisation_gate;
  options.target.slam.diameter_std_m = options_.slam.diameter_std_m;
  // A location prior is required to compare landmark counts: the target's
  // default (a density) unless one is given.
  if (arguments.Has("landmark-prior-std") && arguments.Has("landmark-density"))
    throw UsageError("give either --landmark-prior-std or --landmark-density, not both");
  if (arguments.Has("landmark-prior-std")) {
    options.target.slam.landmark_prior_std_m = options_.slam.landmark_prior_std_m;
    options.target.slam.landmark_density_per_m2 = 0;
  }
  if (arguments.Has("landmark-density") && !options.landmark_density_from_data) {
    options.target.slam.landmark_density_per_m2 = options_.slam.landmark_density_per_m2;
    options.target.slam.landmark_prior_std_m = 0;
  }
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);

  const UnknownAssociationResult result =
      SolveUnknownAssociation(data, options, [&](const std::string& line) {
        if (!quiet) std::printf("%s\n", line.c_str());
        std::fflush(stdout);
      });
  const LandmarkSlamResult& solution = result.solution;
  const std::string output = arguments.Get("output");
  const std::string trajectory_path = WriteMapAndTrajectory(
      output, options_.trajectory, data, solution, options_.class_name,
      "unknown (O-SLAM hill climbing" + std::string(options.samples > 0 ? " + MC3" : "") +
          ", seed " + std::to_string(options.seed) + ")");
  if (!options_.association_out.empty()) {
    std::ostringstream out;  // the --association format: one id per sighting
    for (int id : result.association) out << id << '\n';
    WriteTextFileAtomically(options_.association_out, out.str());
  }
  if (quiet) return 0;

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
  const NoiseScales& n = result.noise_scales;
  if (options.calibrate_on_tracks || options.calibration_rounds > 0)
    std::printf(
        "noise: the stated variances times %.3g (range), %.3g (bearing), %.3g (point), %.3g "
        "(odometry translation), %.3g (heading); calibration %.2f s\n",
        n.range, n.bearing, n.point, n.odometry_translation, n.odometry_heading,
        result.calibration_time_s);
  if (data.has_landmark_ids) PrintAgainstFileIds(data, options, result, options_.truth_trajectory);
  PrintGpsError(options_.gps, options_.gps_antenna, data, solution.trajectory);
  std::printf("wrote %s and %s\n", output.c_str(), trajectory_path.c_str());
  return 0;
}

}  // namespace oslam
