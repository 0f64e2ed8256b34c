#include "pipeline/run_report.h"

#include <algorithm>
#include <filesystem>
#include <set>
#include <sstream>

#include "association/moves.h"
#include "core/angles.h"
#include "core/text.h"
#include "export/export_files.h"
#include "export/figures.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

std::string Fixed(double value, int digits) {
  return Format("%.*f", digits, value);
}

std::string Percent(long part, long whole) {
  return whole > 0 ? Format("%.1f %%", 100.0 * static_cast<double>(part) / whole) : "–";
}

void InputSection(const std::string& run_dir, const RunPipelineOptions& options,
                  const RunPipelineResult& result, std::ostringstream& md) {
  md << "# oslam run\n\noslam " OSLAM_VERSION "; input `" << run_dir << "`; output files are "
     << "listed in docs/export.md.\n\n";
  md << "![bird's-eye view](birdseye.png) ![perspective view](perspective.png)\n\n";
  if (result.metrics) md << "![trajectory error](trajectories.png)\n\n";
  md << "3D map: `map.glb` (Blender: File > Import > glTF 2.0), `map.ply` (MeshLab); "
        "trajectories in TUM format (`trajectory_*.txt`, for evo).\n\n";

  md << "## Input and configuration\n\n| | |\n|---|---|\n";
  if (result.selection)
    md << "| odometry by time | " << result.selection->Summary()
       << ", as the run folder `run/` |\n";
  md << "| frames | " << result.detect.frames;
  if (result.detect.skipped_frames > 0)
    md << " (" << result.detect.skipped_frames << " unreadable, skipped)";
  md << " |\n| detections | " << result.detect.detections.size();
  if (result.detect.sift_rejected > 0)
    md << " (" << result.detect.sift_rejected << " more rejected by SIFT verification)";
  md << " |\n| tracks | " << result.slam.num_tracks << " (of "
     << result.slam.tracks.num_tracks_before_filter << " before dropping those shorter than "
     << options.slam.tracks.min_length << " detections) |\n";
  md << "| method | " << SlamMethodName(options.slam.method);
  if (options.slam.method == SlamMethod::kOSlam) {
    const SamplerOptions sampler = options.slam.EffectiveSampler();
    md << ": MC³ with " << sampler.num_chains << " chains, " << sampler.num_iterations
       << " iterations (the first " << sampler.burn_in << " burn-in), seed " << sampler.seed;
  }
  md << " |\n| ground truth | "
     << (result.metrics ? std::to_string(result.metrics->true_objects_total) + " objects"
                        : std::string("none"))
     << " |\n| configuration | `config.yaml` (every parameter, with its meaning) |\n\n";
}

void TimingSection(const RunPipelineResult& result, std::ostringstream& md) {
  md << "## Timings\n\nWall time and CPU time of all threads, seconds.\n\n"
        "| stage | wall s | CPU s |\n|---|---|---|\n";
  for (const StageTime& t : result.times)
    md << "| " << t.name << " | " << Fixed(t.seconds, 2) << " | " << Fixed(t.cpu_seconds, 2)
       << " |\n";
  const StageTime total = result.Total();
  md << "| total | " << Fixed(total.seconds, 2) << " | " << Fixed(total.cpu_seconds, 2) << " |\n\n";
  // The sampler's own run times: omap.json leaves them out so that the same
  // input and seed give the same file.
  if (result.slam.timing.empty()) return;
  md << "## Run times of the sampler\n\n";
  for (const OMapReport& report : result.slam.timing)
    md << "- " << report.name << ": `" << report.json << "`\n";
  md << "\n";
}

void ObjectSection(const RunPipelineOptions& options, const RunPipelineResult& result,
                   std::ostringstream& md) {
  const double shown_from = options.export_.min_existence;
  const long left_out = std::count_if(
      result.map.objects.begin(), result.map.objects.end(),
      [shown_from](const OMapObject& o) { return o.existence_probability < shown_from; });
  md << "## Objects\n\n" << result.map.objects.size() << " objects; π is the existence probability";
  if (left_out > 0)
    md << ". " << (left_out == 1 ? "One" : std::to_string(left_out)) << " with π < "
       << Fixed(shown_from, 2) << " (export.min_existence) " << (left_out == 1 ? "is" : "are")
       << " listed here only: the 3D files and the figures "
       << "leave " << (left_out == 1 ? "it" : "them") << " out";
  md << ". Base point (centre of the bottom face) in the world frame (Z up), metres.\n\n"
        "| id | class | π | in 3D files | x | y | z | diameter | height | detections |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const OMapObject& o : result.map.objects) {
    md << "| " << o.id << " | " << o.class_name << " | " << Fixed(o.existence_probability, 2)
       << " | " << (o.existence_probability >= shown_from ? "yes" : "no") << " | "
       << Fixed(o.base_world.x(), 2) << " | " << Fixed(o.base_world.y(), 2) << " | "
       << Fixed(o.base_world.z(), 2) << " | " << Fixed(o.diameter_m, 2) << " | "
       << Fixed(o.height_m, 2) << " | " << o.num_detections << " |\n";
  }
  md << "\n";
}

void MoveRows(const char* phase, const std::array<MoveStatistics, kNumMoveTypes>& moves,
              std::ostringstream& md) {
  for (int type = 0; type < kNumMoveTypes; ++type) {
    const MoveStatistics& s = moves[type];
    if (s.proposed == 0) continue;
    md << "| " << phase << " | " << MoveName(static_cast<MoveType>(type)) << " | " << s.proposed
       << " | " << s.accepted << " | " << Percent(s.accepted, s.proposed) << " | "
       << s.self_transitions << " | " << s.screened_out << " |\n";
  }
}

void SamplerSection(const RunPipelineOptions& options, const SamplerSummary& s,
                    const std::string& trace_figure, std::ostringstream& md) {
  const size_t burn_in =
      std::min(s.cold_trace.size(), static_cast<size_t>(options.slam.sampler.burn_in));
  const std::vector<double> kept(s.cold_trace.begin() + static_cast<long>(burn_in),
                                 s.cold_trace.end());
  const std::set<double> distinct(kept.begin(), kept.end());
  const double best =
      kept.empty() ? s.hill_climbed_log_target : *std::max_element(kept.begin(), kept.end());
  md << "## Sampler convergence\n\n";
  if (!trace_figure.empty()) md << "![sampler trace](" << trace_figure << ")\n\n";
  md << "Log target: log P(association, classes | detections, odometry) up to a constant, in "
        "nats (docs/method.md §8).\n\n| | |\n|---|---|\n"
     << "| start | " << Fixed(s.initial_log_target, 1) << " |\n"
     << "| after hill climbing (" << s.hill_climb_steps << " steps, " << s.sweeps
     << " sweeps changing " << s.sweep_changes << ") | " << Fixed(s.hill_climbed_log_target, 1)
     << " |\n"
     << "| highest of the cold chain after burn-in | " << Fixed(best, 1) << " |\n"
     << "| effective sample size | " << Fixed(s.effective_sample_size, 0) << " of " << kept.size()
     << " iterations after burn-in (of the cold chain's log target; integrated autocorrelation, "
        "initial positive sequence) |\n"
     << "| distinct log-target values after burn-in | " << distinct.size() << " |\n"
     << "| chain swaps accepted | " << s.swaps_accepted << " of " << s.swaps_proposed << " ("
     << Percent(s.swaps_accepted, s.swaps_proposed) << ") |\n";
  if (!s.scan_tracks.empty())
    md << "| track scan of the cold chain | " << s.scan_tracks.size() << " contested tracks, "
       << s.track_scan.proposed << " updates, " << s.track_scan.self_transitions
       << " drawing the track's own place, " << s.track_scan.accepted << " moving it ("
       << Fixed(s.track_scan.time_s, 2) << " s) |\n";
  md << "\n";
  md << "Moves of the cold chain. Acceptance = accepted / proposed; a no-op proposal (nothing "
        "to propose, such as a merge with no partner) counts as proposed and not accepted; "
        "screened out = "
        "rejected by the cheap first stage of delayed acceptance without a solve.\n\n"
        "| phase | move | proposed | accepted | acceptance | no-op | screened out |\n"
        "|---|---|---|---|---|---|---|\n";
  MoveRows("hill climbing", s.hill_climb, md);
  MoveRows("MC³", s.sampling, md);
  md << "\n";
}

void ScoreSection(const RunPipelineOptions& options, const MapMetrics& m, std::ostringstream& md) {
  const MapMetricsOptions& eval = options.eval.metrics;
  md << "## Scores against ground truth\n\nThe same numbers as `eval.json` (its key in "
        "brackets). Trajectory errors are horizontal (x, y): the poses are planar.\n\n"
        "| score | estimate | odometry | definition |\n|---|---|---|---|\n";
  md << "| ATE (`ate_rmse_m`) | " << Fixed(m.estimate.ate_rmse_m, 3) << " m | "
     << Fixed(m.odometry.ate_rmse_m, 3)
     << " m | root mean square horizontal distance to the true position over all frames, no "
        "alignment (both start at the true first pose) |\n";
  md << "| RPE step (`rpe_translation_rmse_m`) | " << Fixed(m.estimate.rpe_translation_rmse_m, 4)
     << " m | " << Fixed(m.odometry.rpe_translation_rmse_m, 4)
     << " m | root mean square error of each frame-to-frame horizontal motion |\n";
  md << "| RPE yaw (`rpe_rotation_rmse_rad`) | "
     << Fixed(RadToDeg(m.estimate.rpe_rotation_rmse_rad), 3) << "° | "
     << Fixed(RadToDeg(m.odometry.rpe_rotation_rmse_rad), 3)
     << "° | the same for the heading change |\n\n";

  md << "Objects: a map object counts when π > " << Fixed(eval.existence_threshold, 2)
     << "; map and true objects are matched one to one by horizontal base-point distance, at "
        "most "
     << Fixed(eval.match_gate_m, 2)
     << " m apart.\n\n| score | value | definition |\n|---|---|---|\n";
  md << "| found (`true_objects_found`) | " << m.true_objects_found << " of "
     << m.true_objects_total << " | true objects with a matched map object |\n";
  md << "| spurious (`spurious_objects`) | " << m.spurious_objects
     << " | map objects matched to no true object |\n";
  md << "| class accuracy (`class_accuracy`) | " << Fixed(m.class_accuracy, 3)
     << " | share of matches whose most probable class is the true one |\n";
  md << "| 3D position error, median (`object_position_error_median_m`) | "
     << Fixed(m.object_position_error_median_m, 3)
     << " m | median 3D distance between matched base points |\n";
  md << "| horizontal position error, median (`object_horizontal_error_median_m`) | "
     << Fixed(m.object_horizontal_error_median_m, 3)
     << " m | the same on the floor (x, y), leaving out the base point's height |\n";
  md << "| diameter error, mean (`diameter_error_mean_m`) | " << Fixed(m.diameter_error_mean_m, 3)
     << " m | mean of \\|map − true\\| over the matches |\n";
  md << "| height error, mean (`height_error_mean_m`) | " << Fixed(m.height_error_mean_m, 3)
     << " m | the same for the height |\n\n";
  if (m.matches.empty()) return;
  md << "| true class | map id | map class | 3D error m | horizontal error m | diameter error m | "
        "height error m |\n|---|---|---|---|---|---|---|\n";
  for (const ObjectMatch& match : m.matches)
    md << "| " << match.true_class << " | " << match.map_id << " | " << match.map_class << " | "
       << Fixed(match.position_error_m, 3) << " | " << Fixed(match.horizontal_error_m, 3) << " | "
       << Format("%+.3f", match.diameter_error_m) << " | " << Format("%+.3f", match.height_error_m)
       << " |\n";
  if (m.missed_classes.empty()) return;
  md << "\nNot found:";
  for (size_t i = 0; i < m.missed_classes.size(); ++i)
    md << (i ? ", " : " ") << m.missed_classes[i];
  md << ".\n";
}

}  // namespace

std::string RunReport(const std::string& run_dir, const RunPipelineOptions& options,
                      const RunPipelineResult& result, const std::string& trace_figure) {
  std::ostringstream md;
  InputSection(run_dir, options, result, md);
  TimingSection(result, md);
  ObjectSection(options, result, md);
  if (options.slam.method == SlamMethod::kOSlam && !result.slam.sampler.summary.cold_trace.empty())
    SamplerSection(options, result.slam.sampler.summary, trace_figure, md);
  if (result.metrics) ScoreSection(options, *result.metrics, md);
  return md.str();
}

std::string WriteSamplerTrace(const SamplerSummary& sampler, const std::string& out_dir) {
  if (sampler.cold_trace.empty()) return "";
  const double reference = sampler.hill_climbed_log_target;
  PlotSeries climb, cold;
  climb.name = "hill climbing (steps ≤ 0)";
  climb.column = "hill_climbing";
  climb.rgb = {90, 90, 90};
  climb.dashed = true;
  const long steps = static_cast<long>(sampler.hill_climb_trace.size());
  for (long i = 0; i < steps; ++i) {
    climb.x.push_back(static_cast<double>(i - (steps - 1)));
    climb.y.push_back(sampler.hill_climb_trace[i] - reference);
  }
  cold.name = "MC³ cold chain";
  cold.column = "cold_chain";
  cold.rgb = {31, 119, 180};
  for (size_t i = 0; i < sampler.cold_trace.size(); ++i) {
    cold.x.push_back(static_cast<double>(i + 1));
    cold.y.push_back(sampler.cold_trace[i] - reference);
  }
  FigureOptions size;
  size.width_px = 800;
  size.height_px = 400;
  Figure figure = LinePlotFigure("Sampler trace: log target relative to the hill-climbed state",
                                 "step / iteration", "Δ log target [nats]", {climb, cold}, size);
  figure.csv.replace(0, 1, "iteration");
  WriteFigureFiles(figure, out_dir, "sampler_trace");
  return "sampler_trace.png";
}

std::string InputSummary(const RunPipelineResult& result) {
  return Format("%zu frames, %zu detections, %zu tracks", result.detect.frames,
                result.detect.detections.size(), result.slam.num_tracks);
}

}  // namespace oslam
