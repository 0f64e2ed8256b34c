// oslam slam: O-SLAM (spec §6-§9, Algorithm 9) on a run folder's detections:
// tracks, hill climbing, MC³ over (C, J), fusion of the samples into an O-Map
// with existence probabilities and class histograms; or the nearest-neighbour
// baseline. Prints a convergence report and, when the run has ground truth,
// its scores.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "apps/slam_options.h"
#include "calib/camera_io.h"
#include "core/angles.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"
#include "association/nn_baseline.h"
#include "omap/evaluation.h"
#include "omap/omap_json.h"
#include "association/omap_fusion.h"
#include "association/sampled_omap.h"
#include "association/sampler.h"
#include "association/slam_target.h"
#include "association/tracks.h"

namespace oslam {
namespace {

void AddOptions(Arguments* a) {
  a->AddPositional("RUN_DIR", "run folder (camera.yaml, classes.yaml, odometry.csv)");
  a->AddOption("output", "-o", "OMAP.json", "where to write the O-Map (atomically)");
  a->AddOption("detections", "", "FILE", "detections CSV (default RUN_DIR/detections.csv)");
  AddSlamOptions(a);
  a->AddFlag("quiet", "print nothing but errors");
}

struct Input {
  std::unique_ptr<CameraModel> camera;
  SlamTargetData data;
  std::vector<std::string> class_names;
  std::optional<ConfusionMatrix> confusion;
  TrackSet tracks;
  std::vector<Pose2> odometry;
};

Input Load(const Arguments& arguments, const SlamSettings& settings) {
  const std::string run_dir = arguments.Get("RUN_DIR");
  const RunFolderPaths paths = RunFolderPaths::Of(run_dir);
  Input input;
  input.camera = LoadCamera(paths.camera);
  const std::vector<ObjectClass> classes = ReadClasses(paths.classes);
  for (const ObjectClass& c : classes) {
    if (!(c.diameter_std_m > 0) || !(c.height_std_m > 0))
      throw Error::InFile(paths.classes, "class '" + c.name + "' needs a proper size prior");
    ClassPrior prior;
    prior.name = c.name;
    prior.size_mean_m = {c.diameter_mean_m, c.height_mean_m};
    prior.size_std_m = {c.diameter_std_m, c.height_std_m};
    prior.location_std_m = {settings.location_std_xy_m, settings.location_std_xy_m,
                            settings.location_std_z_m};
    input.data.classes.push_back(prior);
    input.class_names.push_back(c.name);
  }
  input.confusion = ReadConfusion(paths.classes);
  const Odometry odometry = ReadOdometry(paths.odometry);
  input.data.increments = odometry.increments;
  input.data.first_pose = odometry.poses.front();
  input.odometry = odometry.poses;
  const std::string detections_path =
      arguments.Has("detections") ? arguments.Get("detections") : run_dir + "/detections.csv";
  const long frames = static_cast<long>(odometry.increments.size());
  for (const Detection& d : ReadDetections(detections_path, classes)) {
    if (d.frame < 0 || d.frame >= frames)
      throw Error::InFile(detections_path,
                          "frame " + std::to_string(d.frame) + " is beyond the odometry's frames");
    if (d.slice.u_r_px > 1.0) input.data.detections.push_back({d.frame, d.class_index, d.slice});
  }
  input.tracks = BuildTracks(input.data.detections, settings.tracks);
  input.data.tracks = input.tracks.tracks;
  input.data.camera = input.camera.get();
  return input;
}

void PrintMoves(const char* phase, const std::array<MoveStatistics, 3>& stats) {
  for (int m = 0; m < 3; ++m) {
    const MoveStatistics& s = stats[m];
    std::printf(
        "  %s %-6s proposed %5ld  self %5ld  cached %5ld  screened out %5ld  accepted %5ld "
        "(%.1f%% of proposed)  %.2f ms/proposal\n",
        phase, MoveName(static_cast<MoveType>(m)), s.proposed, s.self_transitions, s.cache_hits,
        s.screened_out, s.accepted, s.proposed ? 100.0 * s.accepted / s.proposed : 0.0,
        s.evaluated() > 0 ? 1e3 * s.time_s / s.evaluated() : 0.0);
  }
}

void PrintReport(const SamplerResult& result) {
  const SamplerSummary& s = result.summary;
  std::printf("hill climbing: %d steps, log target %.2f -> %.2f in %.2f s\n", s.hill_climb_steps,
              s.initial_log_target, s.hill_climbed_log_target, s.hill_climb_time_s);
  PrintMoves("hill", s.hill_climb);
  std::printf("MC3: %zu samples in %.2f s; swaps %ld/%ld accepted; ESS(log target) %.1f\n",
              result.samples.size(), s.sampling_time_s, s.swaps_accepted, s.swaps_proposed,
              s.effective_sample_size);
  PrintMoves("mc3 ", s.sampling);
  long proposals = 0;
  for (const auto* phase : {&s.hill_climb, &s.sampling})
    for (const MoveStatistics& m : *phase) proposals += m.proposed;
  std::printf(
      "solves %zu (and %zu run ahead, then undone), cache hits %zu; best log target %.2f; %.0f "
      "cold-chain proposals/s\n",
      s.num_solves, s.speculative_solves_undone, s.num_cache_hits, result.best->log_target,
      proposals / std::max(1e-9, s.hill_climb_time_s + s.sampling_time_s));
  const size_t n = s.cold_trace.size();
  std::printf("cold-chain log target trace:");
  for (size_t i = 0; i < n; i += std::max<size_t>(1, n / 10)) std::printf(" %.1f", s.cold_trace[i]);
  std::printf("\n");
}

}  // namespace

int RunSlamCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam slam RUN_DIR -o OMAP.json [options]",
                      "O-SLAM: data association and classes by hill climbing and MC3 over the "
                      "detections' tracks; writes the O-Map with existence probabilities.");
  AddOptions(&arguments);
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("give the output file with -o OMAP.json");
  if (arguments.Has("baseline") && arguments.Get("baseline") != "nn")
    throw UsageError("--baseline takes 'nn' (nearest neighbour)");
  const SlamSettings settings = SlamSettingsFrom(arguments);
  const bool quiet = arguments.Flag("quiet"), known = settings.known_classes;
  const TrackOptions& track_options = settings.tracks;
  const FusionOptions& fusion_options = settings.fusion;
  const SlamTargetOptions& target_options = settings.target;
  const SamplerOptions& sampler_options = settings.sampler;

  const Input input = Load(arguments, settings);
  if (input.tracks.tracks.empty()) throw Error("no tracks: no detections survived pre-association");
  // The class decisions each track counts for (SlamSettings::class_likelihood_per_detection).
  std::vector<int> track_class, track_size, track_detections;
  for (const Track& t : input.tracks.tracks) {
    track_class.push_back(t.class_index);
    track_detections.push_back(static_cast<int>(t.detections.size()));
    track_size.push_back(settings.class_likelihood_per_detection ? track_detections.back() : 1);
  }
  const int num_classes = static_cast<int>(input.class_names.size());
  const ClassConfusionModel model =
      (input.confusion && !known)
          ? ClassConfusionModel(*input.confusion, settings.confusion_floor, track_class, track_size)
          : ClassConfusionModel::Identity(num_classes, settings.confusion_floor, track_class,
                                          track_size);
  const TrackSummary& ts = input.tracks.summary;
  if (!quiet)
    std::printf(
        "%d detections -> %zu tracks (%d links, %d across gaps; %d dropped in tracks shorter "
        "than %d)\n",
        ts.num_detections, input.tracks.tracks.size(), ts.num_links, ts.num_gap_links,
        ts.num_dropped_detections, track_options.min_length);

  auto factory = [&] { return std::make_unique<SlamEvaluator>(input.data, model, target_options); };
  SamplerResult result;
  OMapSource source{arguments.Get("RUN_DIR"), "", arguments.Get("detections"), std::nullopt, 0};
  const AssociationState start = SeparateTracksState(track_class);
  const auto clock = std::chrono::steady_clock::now();
  if (arguments.Has("baseline")) {
    SlamEvaluator evaluator(input.data, model, target_options);
    const EvaluationPtr separate = evaluator.Refine(start, nullptr);
    const EvaluationPtr solved =
        evaluator.Refine(NearestNeighbourAssociation(*separate, settings.baseline), separate.get());
    result.samples = {solved};
    char gate[64];
    std::snprintf(gate, sizeof(gate), "nearest neighbour (gated, %g m)", settings.baseline.gate_m);
    source.association = gate;
  } else {
    Progress progress("o-slam", sampler_options.hill_climb_steps + sampler_options.num_iterations,
                      "steps", quiet);
    Sampler sampler(model, factory, sampler_options);
    result = sampler.Run(start, [&](const char* stage, size_t done, size_t) {
      progress.Update(std::string(stage) == "MC3" ? sampler_options.hill_climb_steps + done : done);
    });
    progress.Done();
    source.association = sampler_options.num_chains > 1 ? "o-slam (MC3)" : "o-slam (MH)";
    source.seed = sampler_options.seed;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - clock).count();
  const FusionResult fused =
      FuseSamples(result.samples, input.data.classes, track_detections, fusion_options);
  WriteOMap(arguments.Get("output"),
            ToOMap(fused, source, arguments.Has("baseline") ? nullptr : &result.summary));
  if (quiet) return 0;
  if (!arguments.Has("baseline")) PrintReport(result);
  int above = 0;
  for (const OMapObject& o : fused.map.objects) above += o.existence_probability > 0.5;
  size_t members = 0;
  for (const FusedIdentity& f : fused.identities) members += f.members.size();
  std::printf("%zu map objects (from %zu sample identities), %d with pi > 0.5; %.2f s\n",
              fused.map.objects.size(), members, above, seconds);
  if (const auto truth = ReadGroundTruth(arguments.Get("RUN_DIR"))) {
    const MapMetrics s = EvaluateMap(fused.map, input.odometry, *truth);
    std::printf(
        "vs ground truth: ATE %.3f m (odometry %.3f m); found %d/%d at pi > 0.5, "
        "spurious %d; class correct %d/%d; horizontal position median %.3f m, max %.3f m\n",
        s.estimate.ate_rmse_m, s.odometry.ate_rmse_m, s.true_objects_found, s.true_objects_total,
        s.spurious_objects, s.class_correct, s.true_objects_found,
        s.object_horizontal_error_median_m, s.object_horizontal_error_max_m);
    for (const std::string& name : s.missed_classes) std::printf("  missed: %s\n", name.c_str());
  }
  std::printf("wrote %s\n", arguments.Get("output").c_str());
  return 0;
}

}  // namespace oslam
