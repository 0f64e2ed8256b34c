// The binding tables: every configuration key of `oslam run` reaches its
// struct field through a YAML file, through --set and through the single
// command's flag; the defaults shown in --help and in the configuration are
// the options structs' own; the parsers and their messages.
#include "apps/bindings.h"

#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <set>

#include <gtest/gtest.h>

#include "apps/run_config.h"
#include "apps/stage_bindings.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

struct KeyCase {
  std::string key;    // section.key
  std::string value;  // not the default
  std::function<bool(const RunPipelineOptions&)> reached;
};

using O = const RunPipelineOptions&;

// One case per configuration key: a value that is not the default, and the
// field it must reach.
std::vector<KeyCase> Cases() {
  return {
      {"detect.min_area_px", "25", [](O o) { return o.detect.detector.min_area_px == 25; }},
      {"detect.opening_radius_px", "0",
       [](O o) { return o.detect.detector.opening_radius_px == 0; }},
      {"detect.colour_box", "yuv",
       [](O o) { return o.detect.detector.colour.shape == ColourBoxShape::kYuv; }},
      {"detect.brightness_range", "3.5",
       [](O o) { return o.detect.detector.colour.brightness_range == 3.5; }},
      {"detect.keep_look_alikes", "1", [](O o) { return !o.detect.detector.separate_look_alikes; }},
      {"detect.max_shape_distance", "4",
       [](O o) { return o.detect.detector.max_shape_distance == 4.0; }},
      {"detect.max_blob_colour_distance", "4.5",
       [](O o) { return o.detect.detector.max_blob_colour_distance == 4.5; }},
      {"detect.max_view_distance", "inf",
       [](O o) { return std::isinf(o.detect.detector.max_view_distance); }},
      {"detect.fragment_gap_px", "7", [](O o) { return o.detect.detector.fragment_gap_px == 7.0; }},
      {"detect.join_fragments", "0", [](O o) { return !o.detect.detector.join_fragments; }},
      {"detect.drop_fragments", "0", [](O o) { return !o.detect.detector.drop_fragments; }},
      {"detect.sift_templates", "t.yaml", [](O o) { return o.detect.sift_templates == "t.yaml"; }},
      {"detect.threads", "3", [](O o) { return o.detect.threads == 3; }},
      {"detect.skip_bad_frames", "1", [](O o) { return o.detect.skip_bad_frames; }},
      {"slam.class_geometry_evidence", "0",
       [](O o) { return !o.slam.fusion.class_geometry_evidence; }},
      {"slam.existence_given_class", "1", [](O o) { return o.slam.fusion.existence_given_class; }},
      {"slam.split_sampler", "one-or-uniform",
       [](O o) { return o.slam.sampler.moves.split_sampler == SplitSampler::kOneTrackOrUniform; }},
      {"slam.lookalike_size_std_m", "0.7",
       [](O o) { return o.slam.fusion.lookalike_size_std_m == 0.7; }},
      {"slam.lookalike_base_std_m", "1.5",
       [](O o) { return o.slam.fusion.lookalike_base_std_m == 1.5; }},
      {"slam.lookalike_prior", "0.3", [](O o) { return o.slam.fusion.lookalike_prior == 0.3; }},
      {"slam.method", "nn", [](O o) { return o.slam.method == SlamMethod::kNearestNeighbour; }},
      {"slam.seed", "17", [](O o) { return o.slam.sampler.seed == 17; }},
      {"slam.samples", "300", [](O o) { return o.slam.sampler.num_iterations == 300; }},
      {"slam.burn_in", "30", [](O o) { return o.slam.sampler.burn_in == 30; }},
      {"slam.hill_climb", "40", [](O o) { return o.slam.sampler.hill_climb_steps == 40; }},
      {"slam.hill_climb_patience", "9",
       [](O o) { return o.slam.sampler.hill_climb_patience == 9; }},
      {"slam.hill_climb_max", "900",
       [](O o) { return o.slam.sampler.hill_climb_max_steps == 900; }},
      {"slam.refine_every", "7", [](O o) { return o.slam.sampler.refine_every == 7; }},
      {"slam.hill_climb_moves", "0.5,0.5,0",
       [](O o) { return o.slam.sampler.hill_climb_moves.merge == 0.5; }},
      {"slam.sampling_moves", "0.4,0.3,0.2,0.1",
       [](O o) {
         return o.slam.sampler.sampling_moves.split == 0.3 &&
                o.slam.sampler.sampling_moves.reassign == 0.1;
       }},
      {"slam.chains", "2", [](O o) { return o.slam.sampler.num_chains == 2; }},
      {"slam.cold_chain_steps", "1", [](O o) { return o.slam.sampler.cold_chain_steps == 1; }},
      {"slam.track_scan", "6", [](O o) { return o.slam.sampler.track_scan_max == 6; }},
      {"slam.track_scan_nats", "4.5", [](O o) { return o.slam.sampler.track_scan_nats == 4.5; }},
      {"slam.delta_t", "1.5", [](O o) { return o.slam.sampler.delta_temperature == 1.5; }},
      {"slam.known_classes", "1", [](O o) { return o.slam.known_classes; }},
      {"slam.min_track_length", "4", [](O o) { return o.slam.tracks.min_length == 4; }},
      {"slam.track_gate_radius_px", "12",
       [](O o) { return o.slam.tracks.max_radius_change_px == 12; }},
      {"slam.track_gate_angle_rad", "0.1",
       [](O o) { return o.slam.tracks.max_angle_change_rad == 0.1; }},
      {"slam.track_gate_size_change", "0.3",
       [](O o) { return o.slam.tracks.max_relative_size_change == 0.3; }},
      {"slam.track_link_rule", "refuse-ambiguous",
       [](O o) { return o.slam.tracks.link_rule == TrackLinkRule::kRefuseAmbiguous; }},
      {"slam.track_max_gap_frames", "0", [](O o) { return o.slam.tracks.max_gap_frames == 0; }},
      {"slam.proposal_iterations", "3", [](O o) { return o.slam.target.proposal_iterations == 3; }},
      {"slam.linearise_at_reference", "0",
       [](O o) { return !o.slam.target.linearise_at_reference; }},
      {"slam.class_prior_per_object", "1",
       [](O o) { return o.slam.target.class_prior_per_object; }},
      {"slam.mismatch_penalty", "inf",
       [](O o) { return std::isinf(o.slam.sampler.moves.class_mismatch_penalty); }},
      {"slam.merge_distance_m", "0.7",
       [](O o) { return o.slam.sampler.moves.merge_distance_m == 0.7; }},
      {"slam.merge_sigma_m", "0.8", [](O o) { return o.slam.sampler.moves.merge_sigma_m == 0.8; }},
      {"slam.reassign_sigma_m", "1.5",
       [](O o) { return o.slam.sampler.moves.reassign_sigma_m == 1.5; }},
      {"slam.reassign_focus", "4", [](O o) { return o.slam.sampler.moves.reassign_focus == 4; }},
      {"slam.hill_climb_sweeps", "2", [](O o) { return o.slam.sampler.hill_climb_sweeps == 2; }},
      {"slam.class_proposal_uniform", "0",
       [](O o) { return o.slam.sampler.moves.class_proposal_uniform == 0; }},
      {"slam.merge_count_smoothing", "0.2",
       [](O o) { return o.slam.sampler.moves.merge_count_smoothing == 0.2; }},
      {"slam.merge_count_includes_self", "1",
       [](O o) { return o.slam.sampler.moves.merge_count_includes_self; }},
      {"slam.split_sampler", "thesis",
       [](O o) { return o.slam.sampler.moves.split_sampler == SplitSampler::kThesis; }},
      {"slam.confusion_floor", "0.01", [](O o) { return o.slam.confusion_floor == 0.01; }},
      {"slam.location_std_xy_m", "5", [](O o) { return o.slam.location_std_xy_m == 5; }},
      {"slam.location_std_z_m", "1", [](O o) { return o.slam.location_std_z_m == 1; }},
      {"slam.silhouette_model", "0", [](O o) { return !o.slam.silhouette_model; }},
      {"slam.censor_slices", "0", [](O o) { return !o.slam.censor_slices; }},
      {"slam.censor_margin_px", "4", [](O o) { return o.slam.censor_margin_px == 4; }},
      {"slam.bearing_noise_px", "7", [](O o) { return o.slam.bearing_noise_px == 7; }},
      {"slam.support_prior", "0", [](O o) { return !o.slam.support_prior; }},
      {"slam.pixel_noise_px", "15", [](O o) { return o.slam.target.slam.pixel_std_px == 15; }},
      {"slam.motion_add_fwd_m", "0.02",
       [](O o) { return o.slam.target.slam.motion.additive_std[0] == 0.02; }},
      {"slam.motion_add_lat_m", "0.03",
       [](O o) { return o.slam.target.slam.motion.additive_std[1] == 0.03; }},
      {"slam.motion_add_heading_rad", "0.04",
       [](O o) { return o.slam.target.slam.motion.additive_std[2] == 0.04; }},
      {"slam.motion_mult_fwd", "0.2",
       [](O o) { return o.slam.target.slam.motion.multiplicative[0] == 0.2; }},
      {"slam.motion_mult_lat", "0.02",
       [](O o) { return o.slam.target.slam.motion.multiplicative[1] == 0.02; }},
      {"slam.motion_mult_heading", "0.3",
       [](O o) { return o.slam.target.slam.motion.multiplicative[2] == 0.3; }},
      {"slam.motion_noise_is_variance", "1",
       [](O o) { return o.slam.target.slam.motion.entries_are_variances; }},
      {"slam.motion_heading_by_distance", "1",
       [](O o) { return o.slam.target.slam.motion.heading_scales_with_distance; }},
      {"slam.motion_world_frame", "1", [](O o) { return o.slam.target.slam.motion.world_frame; }},
      {"slam.solver_iterations", "9",
       [](O o) { return o.slam.target.slam.solver.max_iterations == 9; }},
      {"slam.solver_step_tolerance", "0.001",
       [](O o) { return o.slam.target.slam.solver.step_tolerance == 0.001; }},
      {"slam.spurious_model", "0", [](O o) { return !o.slam.fusion.spurious_model; }},
      {"slam.spurious_t0_m2", "0.25", [](O o) { return o.slam.fusion.spurious_t0_m2 == 0.25; }},
      {"slam.spurious_tau_m2", "0.01", [](O o) { return o.slam.fusion.spurious_tau_m2 == 0.01; }},
      {"slam.class_likelihood_per_detection", "1",
       [](O o) { return o.slam.class_likelihood_per_detection; }},
      {"slam.swap_every", "3", [](O o) { return o.slam.sampler.swap_every == 3; }},
      {"slam.speculation_depth", "3", [](O o) { return o.slam.sampler.speculation_depth == 3; }},
      {"slam.hill_climb_screen_nats", "inf",
       [](O o) { return std::isinf(o.slam.sampler.hill_climb_screen_nats); }},
      {"slam.delayed_acceptance", "0", [](O o) { return !o.slam.sampler.delayed_acceptance; }},
      {"slam.identity_merge", "0", [](O o) { return !o.slam.fusion.merge_identities; }},
      {"slam.identity_distance_m", "0.9",
       [](O o) { return o.slam.fusion.identity_merge_distance_m == 0.9; }},
      {"slam.identity_mismatch_penalty", "5",
       [](O o) { return o.slam.fusion.identity_class_mismatch_penalty == 5; }},
      {"slam.identity_max_cooccurrence", "0.2",
       [](O o) { return o.slam.fusion.identity_max_cooccurrence == 0.2; }},
      {"slam.nn_gate_m", "0.8", [](O o) { return o.slam.baseline.gate_m == 0.8; }},
      {"export.min_existence", "0.3", [](O o) { return o.export_.min_existence == 0.3; }},
      {"export.overlays", "0", [](O o) { return !o.export_.overlays; }},
      {"export.overlay_frames", "0,5-7", [](O o) { return o.export_.overlay_frames == "0,5-7"; }},
      {"export.threads", "0", [](O o) { return o.export_.threads == 0; }},
      {"export.figure_size_px", "640", [](O o) { return o.export_.figure_size_px == 640; }},
      {"export.floor_grid", "0", [](O o) { return !o.export_.floor_grid; }},
      {"export.ascii_ply", "1", [](O o) { return o.export_.ascii_ply; }},
      {"export.overlay_format", "png", [](O o) { return o.export_.overlay_format == "png"; }},
      {"export.camera_every", "4", [](O o) { return o.export_.camera_every == 4; }},
      {"eval.threshold", "0.7", [](O o) { return o.eval.metrics.existence_threshold == 0.7; }},
      {"eval.gate_m", "0.3", [](O o) { return o.eval.metrics.match_gate_m == 0.3; }},
      {"frames.time_offset_s", "-0.25", [](O o) { return o.frames.time_offset_s == -0.25; }},
      {"frames.min_distance_m", "0.5", [](O o) { return o.frames.min_distance_m == 0.5; }},
      {"frames.min_turn_rad", "0.3", [](O o) { return o.frames.min_turn_rad == 0.3; }},
      {"frames.stride", "3", [](O o) { return o.frames.stride == 3; }},
      {"frames.step_tolerance", "0.1", [](O o) { return o.frames.step_tolerance == 0.1; }},
      {"detect.mask", "m.png", [](O o) { return o.detect.mask == "m.png"; }},
  };
}

// The single command's table of `section`, bound to `options` as the
// command binds its own struct.
void BindSection(const std::string& section, RunPipelineOptions* options, Bindings* bindings) {
  if (section == "detect") BindDetectOptions(&options->detect, bindings);
  if (section == "slam") BindSlamOptions(&options->slam, bindings);
  if (section == "export") BindExportOptions(&options->export_, bindings);
  if (section == "eval") BindEvalOptions(&options->eval, bindings);
  if (section == "frames") BindFrameOptions(&options->frames, bindings);
}

TEST(Bindings, EveryConfigurationKeyReachesItsFieldByFileSetAndFlag) {
  const std::vector<KeyCase> cases = Cases();
  std::set<std::string> keys, covered;
  const RunConfig defaults;
  for (const Bindings* section : defaults.sections())
    for (const Binding& binding : section->entries())
      if (!binding.key().empty()) keys.insert(section->section() + "." + binding.key());
  for (const KeyCase& c : cases) covered.insert(c.key);
  EXPECT_EQ(covered, keys) << "every key needs a case";

  testing::TempDir dir;
  int flags_checked = 0;
  for (const KeyCase& c : cases) {
    SCOPED_TRACE(c.key);
    const size_t dot = c.key.find('.');
    const std::string section = c.key.substr(0, dot), key = c.key.substr(dot + 1);
    EXPECT_FALSE(c.reached(defaults.options())) << "the case's value is the default";

    RunConfig by_set;
    by_set.Override(c.key + "=" + c.value);
    EXPECT_TRUE(c.reached(by_set.options())) << "--set";
    EXPECT_EQ(by_set.Find(section, key)->Value(), c.value);

    std::ofstream(dir.Path("c.yaml")) << section << ":\n  " << key << ": \"" << c.value << "\"\n";
    RunConfig by_file;
    by_file.LoadYaml(dir.Path("c.yaml"));
    EXPECT_TRUE(c.reached(by_file.options())) << "YAML";

    // The single command: its flag, parsed into the same kind of struct.
    RunPipelineOptions options;
    Bindings table;
    BindSection(section, &options, &table);
    const Binding* binding = table.FindKey(key);
    ASSERT_NE(binding, nullptr);
    if (binding->flag().empty()) continue;  // slam.method: --baseline nn, checked below
    Arguments arguments("", "");
    table.Declare(&arguments);
    std::vector<std::string> args = {"--" + binding->flag()};
    if (!binding->is_flag()) {
      args.push_back(c.value);
    } else {
      // A flag sets one value; export.overlays' flag turns on what a run has on.
      RunPipelineOptions flagged;
      Bindings flagged_table;
      BindSection(section, &flagged, &flagged_table);
      Arguments flagged_arguments("", "");
      flagged_table.Declare(&flagged_arguments);
      ASSERT_TRUE(flagged_arguments.Parse(args));
      flagged_table.Apply(flagged_arguments);
      if (flagged_table.FindKey(key)->Value() != c.value) {
        EXPECT_EQ(c.key, "export.overlays");
        continue;
      }
    }
    ASSERT_TRUE(arguments.Parse(args));
    table.Apply(arguments);
    EXPECT_TRUE(c.reached(options)) << "--" << binding->flag();
    ++flags_checked;
  }
  EXPECT_GE(flags_checked, 70);

  RunPipelineOptions baseline;
  Bindings slam;
  BindSlamOptions(&baseline.slam, &slam);
  Arguments arguments("", "");
  slam.Declare(&arguments);
  ASSERT_TRUE(arguments.Parse({"--baseline", "nn"}));
  slam.Apply(arguments);
  EXPECT_EQ(baseline.slam.method, SlamMethod::kNearestNeighbour);
}

// One default per parameter, the struct's: what --help shows is what the
// configuration prints, and both are the default-constructed options.
TEST(Bindings, DefaultsShownAreTheStructs) {
  const RunConfig config;
  for (const Bindings* section : config.sections()) {
    DetectStageOptions detect;
    SlamStageOptions slam;
    ExportStageOptions export_options;
    EvalStageOptions eval;
    Bindings command;
    if (section->section() == "detect") BindDetectOptions(&detect, &command);
    if (section->section() == "slam") BindSlamOptions(&slam, &command);
    if (section->section() == "export") BindExportOptions(&export_options, &command);
    if (section->section() == "eval") BindEvalOptions(&eval, &command);
    Arguments arguments("", "");
    command.Declare(&arguments);
    for (const Binding& binding : section->entries()) {
      if (binding.key().empty() || binding.flag().empty() || binding.is_flag()) continue;
      SCOPED_TRACE(section->section() + "." + binding.key());
      EXPECT_EQ(binding.Value(), binding.default_text());
      EXPECT_EQ(arguments.Get(binding.flag()), binding.Value());  // the --help default
    }
  }
  // Defaults beyond the libraries' structs live in the stage structs.
  EXPECT_EQ(config.Find("slam", "track_max_gap_frames")->Value(), "2");
  EXPECT_EQ(TrackOptions().max_gap_frames, 0);
  EXPECT_EQ(config.Find("export", "min_existence")->Value(), "0.1");
  EXPECT_EQ(config.Find("export", "overlays")->Value(), "1");
  EXPECT_FALSE(ExportStageOptions().overlays);
}

TEST(Bindings, ParsersAndTheirMessages) {
  int count = 5;
  double gate = 1.5, limit = 2;
  bool on = false, separate = true, grid = true;
  std::string text = "x";
  enum class Colour { kRed, kGreen } colour = Colour::kRed;
  Bindings b;
  b.Add(&count, "count", "N", "a count").Check([&] { return count >= 0; }, "must be >= 0");
  b.Add(&gate, "gate", "M", "a gate");
  b.AddNumberOrInfinity(&limit, "limit", "X", "a limit");
  b.AddFlag(&on, "on", "switch on");
  b.AddInvertedFlag(&separate, "together", "keep together").Key("together");
  b.AddNegatedFlag(&grid, "no-grid", "no grid").Key("grid");
  b.Add(&text, "text", "T", "a text").ShowDefault("");
  b.AddChoice(&colour, {{"red", Colour::kRed}, {"green", Colour::kGreen}}, "colour", "C", "");

  EXPECT_EQ(b.FindFlag("count")->default_text(), "5");
  EXPECT_EQ(b.FindFlag("gate")->default_text(), "1.5");
  EXPECT_EQ(b.FindFlag("text")->default_text(), "");
  EXPECT_EQ(b.FindFlag("colour")->default_text(), "red");
  EXPECT_EQ(b.FindFlag("count")->Set("1.5"), ": '1.5' is not an integer");
  EXPECT_EQ(b.FindFlag("count")->Set("99999999999"), ": '99999999999' is out of range");
  EXPECT_EQ(b.FindFlag("count")->Set("-1"), " must be >= 0");
  EXPECT_EQ(b.FindFlag("gate")->Set("inf"), ": 'inf' is not a finite number");
  EXPECT_EQ(b.FindFlag("limit")->Set("x"), ": 'x' is not a number or inf");
  EXPECT_EQ(b.FindFlag("limit")->Set("inf"), "");
  EXPECT_TRUE(std::isinf(limit));
  EXPECT_EQ(b.FindFlag("colour")->Set("blue"), " must be 'red' or 'green', not 'blue'");
  EXPECT_EQ(b.FindKey("together")->Value(), "0");
  EXPECT_EQ(b.FindKey("grid")->Value(), "1");
  EXPECT_EQ(b.FindKey("grid")->Set("yes"), " must be 0 or 1, not 'yes'");

  Arguments arguments("", "");
  b.Declare(&arguments);
  ASSERT_TRUE(
      arguments.Parse({"--on", "--together", "--no-grid", "--colour=green", "--gate", "-2.5"}));
  b.Apply(arguments);
  EXPECT_TRUE(on);
  EXPECT_FALSE(separate);
  EXPECT_FALSE(grid);
  EXPECT_EQ(colour, Colour::kGreen);
  EXPECT_EQ(gate, -2.5);
  EXPECT_EQ(b.FindKey("together")->Value(), "1");

  Arguments bad("", "");
  b.Declare(&bad);
  ASSERT_TRUE(bad.Parse({"--count", "-3"}));
  try {
    b.Apply(bad);
    ADD_FAILURE() << "a negative count passed";
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(), "--count must be >= 0");
  }
}

}  // namespace
}  // namespace oslam
