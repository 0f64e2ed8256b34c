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
#include "calib/camera_io.h"
#include "core/angles.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "detect/blob_detector.h"
#include "mapping/nn_baseline.h"
#include "mapping/omap_evaluation.h"
#include "mapping/omap_fusion.h"
#include "mapping/sampled_omap_json.h"
#include "mapping/sampler.h"
#include "mapping/slam_target.h"
#include "mapping/tracks.h"

namespace oslam {
namespace {

void AddOptions(Arguments* a) {
  a->AddPositional("RUN_DIR", "run folder (camera.yaml, classes.yaml, odometry.csv)");
  a->AddOption("output", "-o", "OMAP.json", "where to write the O-Map (atomically)");
  a->AddOption("detections", "", "FILE", "detections CSV (default RUN_DIR/detections.csv)");
  a->AddOption("seed", "", "N", "seed of the sampler", "1");
  a->AddOption("samples", "", "N", "MC3 iterations including burn-in (spec §13 #21)", "667");
  a->AddOption("burn-in", "", "N", "iterations discarded", "70");
  a->AddOption("hill-climb", "", "N", "hill-climbing steps", "100");
  a->AddOption("chains", "", "N", "MC3 chains (1 = Metropolis-Hastings)", "3");
  a->AddOption("delta-t", "", "DT", "temperature step between chains", "3.33");
  a->AddOption("baseline", "", "nn", "instead of O-SLAM: gated nearest-neighbour association");
  a->AddOption("min-track-length", "", "N", "drop shorter tracks (Sec. 6.3: 3)", "3");
  a->AddOption("max-gap", "", "N",
               "join tracks across up to N missed frames (occlusions; 0 = thesis)", "2");
  a->AddFlag("no-identity-merge",
             "keep one map object per sample identity (thesis Algorithm 3 as printed)");
  a->AddOption("identity-distance", "", "M",
               "identities closer than this that rarely co-occur become one object", "0.5");
  a->AddOption("proposal-iterations", "", "N", "solver iterations per proposed state", "1");
  a->AddOption("mismatch-penalty", "", "X", "class-mismatch factor on e_j (inf = never)", "3");
  a->AddOption("location-std-xy", "", "M", "class location prior std, x and y", "10");
  a->AddOption("location-std-z", "", "M", "class location prior std, z", "2");
  a->AddFlag("known-classes", "assume perfect classes: no switch moves, P_merge = P_split = 0.5");
  a->AddFlag("sequential", "step the chains one after another (same result as threads)");
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

Input Load(const Arguments& arguments, TrackOptions track_options) {
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
    prior.location_std_m = {arguments.GetDouble("location-std-xy"),
                            arguments.GetDouble("location-std-xy"),
                            arguments.GetDouble("location-std-z")};
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
  input.tracks = BuildTracks(input.data.detections, track_options);
  input.data.tracks = input.tracks.tracks;
  input.data.camera = input.camera.get();
  return input;
}

void PrintMoves(const char* phase, const std::array<MoveStatistics, 3>& stats) {
  for (int m = 0; m < 3; ++m) {
    const MoveStatistics& s = stats[m];
    std::printf(
        "  %s %-6s proposed %5ld  self %5ld  cached %5ld  accepted %5ld (%.1f%% of proposed)  "
        "%.2f ms/solve\n",
        phase, MoveName(static_cast<MoveType>(m)), s.proposed, s.self_transitions, s.cache_hits,
        s.accepted, s.proposed ? 100.0 * s.accepted / s.proposed : 0.0,
        s.solves() > 0 ? 1e3 * s.time_s / s.solves() : 0.0);
  }
}

void PrintReport(const SamplerResult& result) {
  const SamplerSummary& s = result.summary;
  std::printf("hill climbing: log target %.2f -> %.2f in %.2f s\n", s.initial_log_target,
              s.hill_climbed_log_target, s.hill_climb_time_s);
  PrintMoves("hill", s.hill_climb);
  std::printf("MC3: %zu samples in %.2f s; swaps %ld/%ld accepted; ESS(log target) %.1f\n",
              result.samples.size(), s.sampling_time_s, s.swaps_accepted, s.swaps_proposed,
              s.effective_sample_size);
  PrintMoves("mc3 ", s.sampling);
  long proposals = 0;
  for (const auto* phase : {&s.hill_climb, &s.sampling})
    for (const MoveStatistics& m : *phase) proposals += m.proposed;
  std::printf(
      "solves %zu, cache hits %zu; best log target %.2f; %.0f cold-chain proposals/s\n",
      s.num_solves, s.num_cache_hits, result.best->log_target,
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
  if (arguments.GetInt("seed") < 0) throw UsageError("--seed must be >= 0");
  const bool quiet = arguments.Flag("quiet"), known = arguments.Flag("known-classes");

  TrackOptions track_options;
  track_options.min_length = static_cast<int>(arguments.GetInt("min-track-length"));
  track_options.max_gap_frames = static_cast<int>(arguments.GetInt("max-gap"));
  FusionOptions fusion_options;
  fusion_options.merge_identities = !arguments.Flag("no-identity-merge");
  fusion_options.identity_merge_distance_m = arguments.GetDouble("identity-distance");
  SlamTargetOptions target_options;
  target_options.proposal_iterations = static_cast<int>(arguments.GetInt("proposal-iterations"));
  SamplerOptions sampler_options;
  sampler_options.seed = static_cast<unsigned long>(arguments.GetInt("seed"));
  sampler_options.num_iterations = static_cast<int>(arguments.GetInt("samples"));
  sampler_options.burn_in = static_cast<int>(arguments.GetInt("burn-in"));
  sampler_options.hill_climb_steps = static_cast<int>(arguments.GetInt("hill-climb"));
  sampler_options.num_chains = static_cast<int>(arguments.GetInt("chains"));
  sampler_options.delta_temperature = arguments.GetDouble("delta-t");
  sampler_options.parallel_chains = !arguments.Flag("sequential");
  sampler_options.moves.class_mismatch_penalty = arguments.GetDouble("mismatch-penalty");
  if (known) {
    sampler_options.sampling_moves = {0.5, 0.5, 0.0};
    sampler_options.moves.class_mismatch_penalty = std::numeric_limits<double>::infinity();
  }
  std::string why;
  if (!track_options.Validate(&why) || !target_options.Validate(&why) ||
      !fusion_options.Validate(&why) ||
      !sampler_options.Validate(&why))
    throw UsageError(why);

  const Input input = Load(arguments, track_options);
  if (input.tracks.tracks.empty()) throw Error("no tracks: no detections survived pre-association");
  std::vector<int> track_class, track_size;
  for (const Track& t : input.tracks.tracks) {
    track_class.push_back(t.class_index);
    track_size.push_back(static_cast<int>(t.detections.size()));
  }
  const int num_classes = static_cast<int>(input.class_names.size());
  const ClassConfusionModel model =
      (input.confusion && !known)
          ? ClassConfusionModel(*input.confusion, 1e-3, track_class, track_size)
          : ClassConfusionModel::Identity(num_classes, 1e-3, track_class, track_size);
  const TrackSummary& ts = input.tracks.summary;
  if (!quiet)
    std::printf(
        "%d detections -> %zu tracks (%d links, %d across gaps; %d dropped in tracks shorter "
        "than %d)\n",
        ts.num_detections, input.tracks.tracks.size(), ts.num_links, ts.num_gap_links,
        ts.num_dropped_detections, track_options.min_length);

  auto factory = [&] { return std::make_unique<SlamEvaluator>(input.data, model, target_options); };
  SamplerResult result;
  SampledOMapSource source{arguments.Get("RUN_DIR"), arguments.Get("detections"), "", 0};
  const AssociationState start = SeparateTracksState(track_class);
  const auto clock = std::chrono::steady_clock::now();
  if (arguments.Has("baseline")) {
    SlamEvaluator evaluator(input.data, model, target_options);
    const EvaluationPtr separate = evaluator.Refine(start, nullptr);
    const EvaluationPtr solved =
        evaluator.Refine(NearestNeighbourAssociation(*separate, {}), separate.get());
    result.samples = {solved};
    source.association = "nearest neighbour (gated, 0.5 m)";
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
  const FusionResult fused = FuseSamples(result.samples, input.data.classes, track_size, fusion_options);
  WriteSampledOMap(arguments.Get("output"), fused, source,
                   arguments.Has("baseline") ? nullptr : &result.summary);
  if (quiet) return 0;
  if (!arguments.Has("baseline")) PrintReport(result);
  int above = 0;
  for (const OMapObject& o : fused.map.objects) above += o.existence_probability > 0.5;
  size_t members = 0;
  for (const FusedIdentity& f : fused.identities) members += f.members.size();
  std::printf("%zu map objects (from %zu sample identities), %d with pi > 0.5; %.2f s\n",
              fused.map.objects.size(), members, above, seconds);
  if (const auto truth = ReadGroundTruth(arguments.Get("RUN_DIR"))) {
    const OMapScore s = ScoreOMap(fused.map, input.odometry, *truth);
    std::printf(
        "vs ground truth: ATE %.3f m (odometry %.3f m); found %d/%d at pi > 0.5, "
        "spurious %d; class correct %d/%d; position median %.3f m, max %.3f m\n",
        s.trajectory_rmse_m, s.odometry_rmse_m, s.found, s.true_objects, s.spurious,
        s.class_correct, s.found, s.position_median_m, s.position_max_m);
    for (const std::string& name : s.missed) std::printf("  missed: %s\n", name.c_str());
  }
  std::printf("wrote %s\n", arguments.Get("output").c_str());
  return 0;
}

}  // namespace oslam
