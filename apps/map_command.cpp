// oslam map: an O-Map by one of three modes (apps/map_modes.h). This file
// has the command and the --known-association mode: setup 1 (docs/method.md §3.3),
// the simulator's true slices with seeded thesis-level noise and their true
// object ids, solved by geometric SLAM.
#include <cstdio>

#include "apps/commands.h"
#include "apps/map_modes.h"
#include "calib/camera_io.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "omap/evaluation.h"
#include "omap/omap_json.h"
#include "slam/slam_omap.h"
#include "solver/summary_report.h"

namespace oslam {

void KnownAssociationMode::Declare(Arguments* arguments) {
  arguments->AddPositional("RUN_DIR",
                           "run folder (camera.yaml, classes.yaml, odometry.csv, ground_truth/)");
  arguments->AddFlag("known-association",
                     "detections = ground-truth slices + noise, associated by object id");
  bindings_.Add(&input_.pixel_noise_px, "pixel-noise", "PX",
                "detection noise E in pixels (thesis: 30)");
  bindings_.Add(&input_.seed, "seed", "N", "seed of the detection noise");
  bindings_.Add(&input_.min_visible_fraction, "min-visible", "FRACTION",
                "drop sightings whose unoccluded share is below this");
  Eigen::Vector3d* location = &input_.location_std_m;
  bindings_.AddCustom(
      "location-std-xy", "M", "class location prior std, x and y",
      [location] { return Number(location->x()); },
      [location](const std::string& text) {
        double value = 0;
        const std::string problem = ParseNumber(text, false, &value);
        if (problem.empty()) location->x() = location->y() = value;
        return problem;
      });
  bindings_.Add(&location->z(), "location-std-z", "M", "class location prior std, z");
  bindings_
      .Add(&slam_.keyframe_start.min_poses, "keyframe-start", "POSES",
           "runs of more poses than this start from a keyframe solve grown stage by stage "
           "instead of raw odometry (0: always raw odometry)")
      .Check([this] { return slam_.keyframe_start.min_poses >= 0; }, "must be >= 0");
  bindings_.AddFlag(&slam_.compute_pose_covariances, "pose-covariances",
                    "also compute every pose's covariance (slower)");
  bindings_.Declare(arguments);
}

int KnownAssociationMode::Run(const Arguments& arguments) {
  if (!arguments.Has("output")) throw UsageError("give the output file with -o OMAP.json");
  bindings_.Apply(arguments);
  std::string why;
  if (!input_.Validate(&why)) throw UsageError(why);
  const std::string run_dir = arguments.Get("RUN_DIR");
  const auto camera = LoadCamera(RunFolderPaths::Of(run_dir).camera);
  const KnownAssociationInput input = LoadKnownAssociation(run_dir, input_);

  // The factor's E: with no added noise keep the thesis value rather than 0.
  slam_.pixel_std_px =
      input_.pixel_noise_px > 0 ? input_.pixel_noise_px : GeometricSlamOptions().pixel_std_px;
  GeometricSlam slam(*camera, slam_);
  const GeometricSlamResult result = slam.Solve(input.problem);
  // A failed solve is no map: say so, naming the run, and write nothing.
  if (!result.summary.IsUsable())
    throw Error::InFile(run_dir, "the solver failed on the run's ground-truth sightings (" +
                                     result.summary.message + "); no map written");

  const OMapSource source{run_dir, "known (ground truth)", std::nullopt, input_.pixel_noise_px,
                          input_.seed};
  const OMap map = ToOMap(result, input.class_names, source);
  WriteOMap(arguments.Get("output"), map);
  if (!arguments.Flag("quiet")) {
    const SolverSummary& s = result.summary;
    std::printf("%zu objects from %zu detections (%d sightings skipped), %zu poses\n",
                result.objects.size(), input.problem.observations.size(), input.skipped_sightings,
                result.trajectory.size());
    const KeyframeStartSummary& start = result.keyframe_start;
    if (start.used)
      std::printf(
          "start: %d keyframes, %d stage solves (%d of them loop closures, all keyframes free), "
          "%.1f ms\n",
          start.num_keyframes, start.stage_solves, start.closures, 1e3 * start.time_s);
    std::printf("solver: %s, %.1f ms\n", BriefReport(s).c_str(), 1e3 * s.total_time_s);
    if (result.evidence.valid)
      std::printf("log evidence %.3f (residual %.3f, log det %.3f)\n", result.evidence.log_evidence,
                  result.evidence.squared_residual, result.evidence.log_det_information);
    MapMetricsOptions by_id;  // the map keeps the true object ids
    by_id.matching = ObjectMatching::kById;
    const MapMetrics errors =
        EvaluateMap(map, ComposeOdometry(input.problem.first_pose, input.problem.increments),
                    input.truth, by_id);
    std::printf(
        "vs ground truth: ATE %.3f m (odometry %.3f m); object position median %.3f m, "
        "max %.3f m; |diameter| %.3f m, |height| %.3f m (means)\n",
        errors.estimate.ate_rmse_m, errors.odometry.ate_rmse_m,
        errors.object_position_error_median_m, errors.object_position_error_max_m,
        errors.diameter_error_mean_m, errors.height_error_mean_m);
    std::printf("wrote %s\n", arguments.Get("output").c_str());
  }
  return 0;
}

int RunMapCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam map RUN_DIR -o OMAP.json [options]\n"
      "       oslam map RUN_DIR --known-association -o OMAP.json [options]\n"
      "       oslam map --landmarks FILE [--format auto|gtsam|g2o|toro|isam|victoria-raw] -o "
      "OMAP.json [options]",
      "Builds an O-Map. Without a mode option: O-SLAM on the run's detections (as 'oslam "
      "slam');\nwith --known-association: geometric SLAM on the ground-truth association; with "
      "--landmarks FILE:\nlandmark SLAM on a range-bearing data set. Each mode takes the "
      "options of its group below.");
  arguments.AddOption("output", "-o", "OMAP.json", "where to write the O-Map (atomically)");
  arguments.AddFlag("quiet", "print nothing but errors");
  SlamMode slam;
  arguments.BeginMode("", "O-SLAM (no mode option; as 'oslam slam')",
                      "oslam map RUN_DIR -o OMAP.json [options]",
                      "O-SLAM: data association and classes by hill climbing and MC3 over the "
                      "detections' tracks; writes the O-Map with existence probabilities.");
  slam.Declare(&arguments);
  KnownAssociationMode known;
  arguments.BeginMode("known-association",
                      "geometric SLAM, association given (--known-association)",
                      "oslam map RUN_DIR --known-association -o OMAP.json [options]",
                      "Geometric SLAM of the run's objects and trajectory; writes the O-Map "
                      "(docs/omap-format.md).");
  known.Declare(&arguments);
  LandmarkMode landmarks;
  arguments.BeginMode(
      "landmarks", "landmark SLAM on a range-bearing data set (--landmarks FILE)",
      "oslam map --landmarks FILE [--format auto|gtsam|g2o|toro|isam|victoria-raw] -o OMAP.json "
      "[options]",
      "Landmark SLAM on a range-bearing data set (docs/formats.md, Landmark data sets) with "
      "the association its landmark ids (or --association) give; writes the O-Map (one 'tree' "
      "object per landmark) and the trajectory CSV.");
  landmarks.Declare(&arguments);
  if (!arguments.Parse(args)) return 0;
  if (arguments.mode() == "known-association") return known.Run(arguments);
  if (arguments.mode() == "landmarks") return landmarks.Run(arguments);
  return slam.Run(arguments);
}

}  // namespace oslam
