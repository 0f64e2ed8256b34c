// oslam map: build an O-Map from a run folder. For now only setup 1 (spec
// §3.3): --known-association takes the simulator's true slices with seeded
// thesis-level noise and their true object ids.
#include <cstdio>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "calib/camera_io.h"
#include "core/error.h"
#include "core/run_folder.h"
#include "slam/geometric_slam.h"
#include "pipeline/known_association.h"
#include "omap/evaluation.h"
#include "omap/omap_json.h"
#include "slam/slam_omap.h"

namespace oslam {

int RunMapCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam map RUN_DIR --known-association -o OMAP.json [options]",
                      "Geometric SLAM of the run's objects and trajectory; writes the O-Map "
                      "(docs/omap-format.md).");
  arguments.AddPositional("RUN_DIR",
                          "run folder (camera.yaml, classes.yaml, odometry.csv, "
                          "ground_truth/)");
  arguments.AddFlag("known-association",
                    "detections = ground-truth slices + noise, associated by object id");
  arguments.AddOption("output", "-o", "OMAP.json", "where to write the O-Map (atomically)");
  arguments.AddOption("pixel-noise", "", "PX", "detection noise E in pixels (thesis: 30)", "30");
  arguments.AddOption("seed", "", "N", "seed of the detection noise", "1");
  arguments.AddOption("min-visible", "", "FRACTION",
                      "drop sightings whose unoccluded share is below this", "0.5");
  arguments.AddOption("location-std-xy", "", "M", "class location prior std, x and y", "10");
  arguments.AddOption("location-std-z", "", "M", "class location prior std, z", "2");
  arguments.AddOption("keyframe-start", "", "POSES",
                      "runs of more poses than this start from a keyframe solve grown stage "
                      "by stage instead of raw odometry (0: always raw odometry)",
                      "2000");
  arguments.AddFlag("pose-covariances", "also compute every pose's covariance (slower)");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Flag("known-association"))
    throw UsageError("only --known-association is implemented so far (spec setup 1)");
  if (!arguments.Has("output")) throw UsageError("give the output file with -o OMAP.json");
  if (arguments.GetInt("seed") < 0) throw UsageError("--seed must be >= 0");
  if (arguments.GetInt("keyframe-start") < 0) throw UsageError("--keyframe-start must be >= 0");

  const std::string run_dir = arguments.Get("RUN_DIR");
  KnownAssociationOptions input_options;
  input_options.pixel_noise_px = arguments.GetDouble("pixel-noise");
  input_options.seed = static_cast<unsigned long>(arguments.GetInt("seed"));
  input_options.min_visible_fraction = arguments.GetDouble("min-visible");
  input_options.location_std_m = {arguments.GetDouble("location-std-xy"),
                                  arguments.GetDouble("location-std-xy"),
                                  arguments.GetDouble("location-std-z")};
  std::string why;
  if (!input_options.Validate(&why)) throw UsageError(why);
  const auto camera = LoadCamera(RunFolderPaths::Of(run_dir).camera);
  const KnownAssociationInput input = LoadKnownAssociation(run_dir, input_options);

  GeometricSlamOptions options;
  // The factor's E: with no added noise keep the thesis value rather than 0.
  options.pixel_std_px = input_options.pixel_noise_px > 0 ? input_options.pixel_noise_px : 30.0;
  options.compute_pose_covariances = arguments.Flag("pose-covariances");
  options.keyframe_start.min_poses = arguments.GetInt("keyframe-start");
  GeometricSlam slam(*camera, options);
  const GeometricSlamResult result = slam.Solve(input.problem);

  OMapSource source{run_dir, "known (ground truth)", std::nullopt, input_options.pixel_noise_px,
                    input_options.seed};
  const OMap map = ToOMap(result, input.class_names, source);
  WriteOMap(arguments.Get("output"), map);
  const bool quiet = arguments.Flag("quiet");
  if (!quiet) {
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
    std::printf("solver: %s (%s), %d iterations, cost %.6g -> %.6g, %.1f ms\n",
                TerminationName(s.termination), s.message.c_str(), s.iterations, s.initial_cost,
                s.final_cost, 1e3 * s.total_time_s);
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
  return result.summary.IsUsable() ? 0 : 1;
}

}  // namespace oslam
