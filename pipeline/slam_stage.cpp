#include "pipeline/slam_stage.h"

#include <cmath>

#include <algorithm>
#include <chrono>
#include <limits>
#include <memory>
#include <optional>

#include "calib/camera_io.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "omap/evaluation.h"
#include "omap/omap_json.h"

namespace oslam {
namespace {

struct LoadedInput {
  std::unique_ptr<CameraModel> camera;
  SlamTargetData data;
  std::vector<std::string> class_names;
  std::optional<ConfusionMatrix> confusion;
  TrackSet tracks;
  std::vector<Pose2> odometry;
  std::string detections_path;  // for messages: where the detections came from
};

LoadedInput Load(const SlamStageInput& input, const SlamStageOptions& options) {
  const RunFolderPaths paths = RunFolderPaths::Of(input.run_dir);
  LoadedInput loaded;
  loaded.camera = LoadCamera(paths.camera);
  const std::vector<ObjectClass> classes = ReadClasses(paths.classes);
  for (const ObjectClass& c : classes) {
    if (!(c.diameter_std_m > 0) || !(c.height_std_m > 0))
      throw Error::InFile(paths.classes, "class '" + c.name + "' needs a proper size prior");
    ClassPrior prior;
    prior.name = c.name;
    prior.size_mean_m = {c.diameter_mean_m, c.height_mean_m};
    prior.size_std_m = {c.diameter_std_m, c.height_std_m};
    prior.location_std_m = {options.location_std_xy_m, options.location_std_xy_m,
                            options.location_std_z_m};
    if (options.support_prior && c.supported) {
      prior.location_mean_m.z() = c.base_height_m;
      prior.location_std_m.z() = c.base_height_std_m;
    }
    if (options.silhouette_model)
      prior.slice_model.silhouette = SilhouetteOf(*loaded.camera, c.shape, c.footprint_aspect);
    prior.slice_model.censor_at_image_limits = options.censor_slices;
    prior.slice_model.censor_margin_px = options.censor_margin_px;
    prior.slice_model.bearing_noise_px = options.bearing_noise_px;
    loaded.data.classes.push_back(prior);
    loaded.class_names.push_back(c.name);
  }
  loaded.confusion = ReadConfusion(paths.classes);
  const Odometry odometry = ReadOdometry(paths.odometry);
  loaded.data.increments = odometry.increments;
  loaded.data.first_pose = odometry.poses.front();
  loaded.odometry = odometry.poses;
  const std::string detections_path =
      input.detections_path.empty() ? paths.detections : input.detections_path;
  loaded.detections_path = detections_path;
  const std::vector<Detection> read =
      input.detections ? std::vector<Detection>() : ReadDetections(detections_path, classes);
  const long frames = static_cast<long>(odometry.increments.size());
  for (const Detection& d : input.detections ? *input.detections : read) {
    if (d.frame < 0 || d.frame >= frames)
      throw Error::InFile(detections_path,
                          "frame " + std::to_string(d.frame) + " is beyond the odometry's frames");
    if (d.slice.u_r_px > 1.0) loaded.data.detections.push_back({d.frame, d.class_index, d.slice});
  }
  loaded.tracks = BuildTracks(loaded.data.detections, options.tracks);
  loaded.data.tracks = loaded.tracks.tracks;
  loaded.data.camera = loaded.camera.get();
  return loaded;
}

void ReportMoves(const char* phase, const std::array<MoveStatistics, kNumMoveTypes>& stats,
                 const StageOutput& output) {
  for (int m = 0; m < kNumMoveTypes; ++m) {
    const MoveStatistics& s = stats[m];
    output.Print(Format(
        "  %s %-6s proposed %5ld  self %5ld  cached %5ld  screened out %5ld  accepted %5ld "
        "(%.1f%% of proposed)  %.2f ms/proposal",
        phase, MoveName(static_cast<MoveType>(m)), s.proposed, s.self_transitions, s.cache_hits,
        s.screened_out, s.accepted, s.proposed ? 100.0 * s.accepted / s.proposed : 0.0,
        s.evaluated() > 0 ? 1e3 * s.time_s / s.evaluated() : 0.0));
  }
}

void ReportSampler(const SamplerResult& result, const StageOutput& output) {
  const SamplerSummary& s = result.summary;
  output.Print(
      Format("hill climbing: %d steps and %d sweeps (%d changes), log target %.2f -> "
             "%.2f in %.2f s",
             s.hill_climb_steps, s.sweeps, s.sweep_changes, s.initial_log_target,
             s.hill_climbed_log_target, s.hill_climb_time_s));
  ReportMoves("hill", s.hill_climb, output);
  output.Print(Format("MC3: %zu samples in %.2f s; swaps %ld/%ld accepted; ESS(log target) %.1f",
                      result.samples.size(), s.sampling_time_s, s.swaps_accepted, s.swaps_proposed,
                      s.effective_sample_size));
  ReportMoves("mc3 ", s.sampling, output);
  long proposals = 0;
  for (const auto* phase : {&s.hill_climb, &s.sampling})
    for (const MoveStatistics& m : *phase) proposals += m.proposed;
  output.Print(Format(
      "solves %zu (and %zu run ahead, then undone), cache hits %zu; best log target %.2f; %.0f "
      "cold-chain proposals/s",
      s.num_solves, s.speculative_solves_undone, s.num_cache_hits, result.best->log_target,
      proposals / std::max(1e-9, s.hill_climb_time_s + s.sampling_time_s)));
  const size_t n = s.cold_trace.size();
  std::string trace = "cold-chain log target trace:";
  for (size_t i = 0; i < n; i += std::max<size_t>(1, n / 10))
    trace += Format(" %.1f", s.cold_trace[i]);
  output.Print(trace);
}

// The map's objects and, when the run has ground truth, its scores.
void ReportMap(const SlamStageResult& result, const std::vector<Pose2>& odometry,
               const std::string& run_dir, const StageOutput& output) {
  int above = 0;
  for (const OMapObject& o : result.fused.map.objects) above += o.existence_probability > 0.5;
  size_t members = 0;
  for (const FusedIdentity& f : result.fused.identities) members += f.members.size();
  output.Print(Format("%zu map objects (from %zu sample identities), %d with pi > 0.5; %.2f s",
                      result.fused.map.objects.size(), members, above, result.seconds));
  if (const auto truth = ReadGroundTruth(run_dir)) {
    const MapMetrics s = EvaluateMap(result.fused.map, odometry, *truth);
    output.Print(
        Format("vs ground truth: ATE %.3f m (odometry %.3f m); found %d/%d at pi > 0.5, "
               "spurious %d; class correct %d/%d; horizontal position median %.3f m, max %.3f m",
               s.estimate.ate_rmse_m, s.odometry.ate_rmse_m, s.true_objects_found,
               s.true_objects_total, s.spurious_objects, s.class_correct, s.true_objects_found,
               s.object_horizontal_error_median_m, s.object_horizontal_error_max_m));
    for (const std::string& name : s.missed_classes) output.Print("  missed: " + name);
  }
}

}  // namespace

const char* SlamMethodName(SlamMethod method) {
  return method == SlamMethod::kNearestNeighbour ? "nn" : "oslam";
}

SamplerOptions SlamStageOptions::EffectiveSampler() const {
  SamplerOptions effective = sampler;
  if (known_classes) {
    // Sec. 6.2: no switch moves (0.4/0.4/0.2 becomes 0.5/0.5/0), never merge across classes.
    MoveProbabilities& p = effective.sampling_moves;
    const double rest = p.merge + p.split + p.reassign;
    if (rest > 0) p = {p.merge / rest, p.split / rest, 0.0, p.reassign / rest};
    effective.moves.class_mismatch_penalty = std::numeric_limits<double>::infinity();
  }
  return effective;
}

bool SlamStageOptions::Validate(std::string* why) const {
  auto fail = [why](const char* what) {
    if (why) *why = what;
    return false;
  };
  if (!(confusion_floor > 0 && confusion_floor < 1))
    return fail("the confusion floor must be in (0, 1)");
  if (!(location_std_xy_m > 0) || !(location_std_z_m > 0))
    return fail("the class location prior's std devs must be > 0 m");
  if (!(censor_margin_px >= 0) || !std::isfinite(censor_margin_px))
    return fail("the censoring margin must be >= 0 px");
  if (!(bearing_noise_px >= 0) || !std::isfinite(bearing_noise_px))
    return fail("the bearing noise must be >= 0 px");
  return tracks.Validate(why) && target.Validate(why) && fusion.Validate(why) &&
         EffectiveSampler().Validate(why) && baseline.Validate(why);
}

SlamStageResult RunSlamStage(const SlamStageInput& input, const std::string& output_json,
                             const SlamStageOptions& options, const StageOutput& output) {
  std::string why;
  if (!options.Validate(&why)) throw Error("o-slam: " + why);
  const SamplerOptions sampler_options = options.EffectiveSampler();
  const LoadedInput loaded = Load(input, options);
  if (loaded.tracks.tracks.empty()) {
    const TrackSummary& s = loaded.tracks.summary;
    throw Error::InFile(
        loaded.detections_path,
        Format("no detection survived pre-association (%d detections, %d of them "
               "in tracks shorter than %d frames)",
               s.num_detections, s.num_dropped_detections, options.tracks.min_length));
  }
  // The class decisions each track counts for (class_likelihood_per_detection).
  std::vector<int> track_class, track_size, track_detections;
  for (const Track& t : loaded.tracks.tracks) {
    track_class.push_back(t.class_index);
    track_detections.push_back(static_cast<int>(t.detections.size()));
    track_size.push_back(options.class_likelihood_per_detection ? track_detections.back() : 1);
  }
  const int num_classes = static_cast<int>(loaded.class_names.size());
  const ClassConfusionModel model =
      (loaded.confusion && !options.known_classes)
          ? ClassConfusionModel(*loaded.confusion, options.confusion_floor, track_class, track_size)
          : ClassConfusionModel::Identity(num_classes, options.confusion_floor, track_class,
                                          track_size);
  SlamStageResult result;
  result.tracks = loaded.tracks.summary;
  result.num_tracks = loaded.tracks.tracks.size();
  const TrackSummary& ts = result.tracks;
  output.Print(
      Format("%d detections -> %zu tracks (%d links, %d across gaps; %d dropped in tracks shorter "
             "than %d)",
             ts.num_detections, result.num_tracks, ts.num_links, ts.num_gap_links,
             ts.num_dropped_detections, options.tracks.min_length));

  result.source = {input.run_dir, "", input.detections_path, std::nullopt, 0};
  const AssociationState start = SeparateTracksState(track_class);
  const auto clock = std::chrono::steady_clock::now();
  const bool baseline = options.method == SlamMethod::kNearestNeighbour;
  // The solver's failures come from the detections (with the odometry and
  // the camera): name them.
  try {
    if (baseline) {
      SlamEvaluator evaluator(loaded.data, model, options.target);
      const EvaluationPtr separate = evaluator.Refine(start, nullptr);
      if (!separate || !separate->valid)
        throw Error("the start state (every track its own object) could not be evaluated");
      const EvaluationPtr solved = evaluator.Refine(
          NearestNeighbourAssociation(*separate, options.baseline), separate.get());
      result.sampler.samples = {solved};
      result.source.association =
          Format("nearest neighbour (gated, %g m)", options.baseline.gate_m);
    } else {
      auto factory = [&] {
        return std::make_unique<SlamEvaluator>(loaded.data, model, options.target);
      };
      const size_t hill = static_cast<size_t>(sampler_options.hill_climb_steps);
      Progress progress("o-slam", hill + sampler_options.num_iterations, "steps", output.quiet);
      Sampler sampler(model, factory, sampler_options);
      result.sampler = sampler.Run(start, [&](const char* stage, size_t done, size_t) {
        progress.Update(std::string(stage) == "MC3" ? hill + done : done);
      });
      progress.Done();
      result.source.association = sampler_options.num_chains > 1 ? "o-slam (MC3)" : "o-slam (MH)";
      result.source.seed = sampler_options.seed;
    }
  } catch (const Error& e) {
    throw Error::InFile(loaded.detections_path,
                        std::string("O-SLAM failed on these detections: ") + e.what());
  }
  result.seconds = SecondsSince(clock);
  result.fused =
      FuseSamples(result.sampler.samples, loaded.data.classes, track_detections, options.fusion);
  const OMap map =
      ToOMap(result.fused, result.source, baseline ? nullptr : &result.sampler.summary);
  WriteOMap(output_json, map);
  result.timing = map.timing;
  if (output.quiet) return result;
  if (!baseline) ReportSampler(result.sampler, output);
  ReportMap(result, loaded.odometry, input.run_dir, output);
  output.Print("wrote " + output_json);
  return result;
}

}  // namespace oslam
