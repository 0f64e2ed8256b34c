// The configuration of `oslam run`: the printed defaults read back to the
// same configuration, they are the mapping code's defaults, every O-SLAM
// parameter has a key, an override reaches the options the sampler gets,
// and bad values are one-line errors naming the file or the key.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "apps/arguments.h"
#include "apps/run_config.h"
#include "apps/stage_bindings.h"
#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

const SlamStageOptions& SettingsOf(const RunConfig& config) {
  return config.options().slam;
}

// Every key's value as text, in file order.
std::vector<std::string> Values(const RunConfig& config) {
  std::vector<std::string> values;
  for (const Bindings* section : config.sections())
    for (const Binding& binding : section->entries())
      if (!binding.key().empty()) values.push_back(binding.Value());
  return values;
}

std::string Message(const std::function<void()>& action) {
  try {
    action();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RunConfig, PrintedDefaultsLoadBackToTheSameConfiguration) {
  testing::TempDir dir;
  const RunConfig defaults;
  std::ofstream(dir.Path("defaults.yaml")) << defaults.ToYaml();
  RunConfig loaded;
  loaded.LoadYaml(dir.Path("defaults.yaml"));
  EXPECT_NO_THROW(loaded.Check());
  EXPECT_EQ(loaded.ToYaml(), defaults.ToYaml());
  EXPECT_EQ(Values(loaded), Values(defaults));

  // A changed value survives the round trip too, at full precision.
  RunConfig changed;
  changed.Override("slam.motion_add_heading_rad=0.0123456789012345");
  changed.Override("slam.mismatch_penalty=inf");
  std::ofstream(dir.Path("changed.yaml")) << changed.ToYaml();
  RunConfig reloaded;
  reloaded.LoadYaml(dir.Path("changed.yaml"));
  EXPECT_EQ(reloaded.ToYaml(), changed.ToYaml());
  EXPECT_EQ(SettingsOf(reloaded).target.slam.motion.additive_std[2], 0.0123456789012345);
  EXPECT_TRUE(std::isinf(SettingsOf(reloaded).sampler.moves.class_mismatch_penalty));
}

// The file written into every output folder: the keys in this order, each
// with its default and meaning (the start of each section is enough to
// catch a reordering or a changed default's text).
TEST(RunConfig, PrintedDefaultsKeepTheirOrderAndText) {
  const std::string yaml = RunConfig().ToYaml();
  for (const char* lines :
       {"detect:\n  min_area_px: 40  # smallest colour blob kept, pixels\n  opening_radius_px: 1",
        "  max_shape_distance: \"inf\"  # drop detections",
        "  sift_templates: \"\"  # templates.yaml for SIFT verification; empty = colour only\n"
        "  threads: 2  # frames decoded and searched at once, 0 = one per core (same output)\n"
        "  skip_bad_frames: 0",
        "slam:\n  method: \"oslam\"  # oslam (MCMC over association and classes) or nn "
        "(baseline)\n  seed: 1  # seed of every random choice of the sampler\n  samples: 1500",
        "  hill_climb_moves: \"0.9,0.1,0\"", "  track_gate_angle_rad: 0.349066  #",
        "  track_link_rule: \"nearest\"", "  track_max_gap_frames: 2  #",
        "  mismatch_penalty: 3  #", "  spurious_model: 1  #",
        "  nn_gate_m: 0.5  # method nn: nearest-neighbour association gate, m\nexport:\n"
        "  min_existence: 0.1  # leave out objects with a lower existence probability\n"
        "  overlays: 1  # 1: draw the map on every frame\n  overlay_frames: \"\"",
        "  overlay_format: \"jpg\"  #",
        "  floor_grid: 1  # 1: a floor grid in the glTF\n  camera_every: 0  #", "  ascii_ply: 0  #",
        "eval:\n  threshold: 0.5  # objects at or below this existence probability are not in "
        "the map\n  gate_m: 0.5  # largest base-point distance of a match, m\n"})
    EXPECT_NE(yaml.find(lines), std::string::npos) << lines << "\nin\n" << yaml;
}

TEST(RunConfig, DefaultsAreTheDocumentedOnesOfTheMappingCode) {
  const RunConfig config;
  const SlamStageOptions& s = SettingsOf(config);
  const SamplerOptions sampler;
  EXPECT_EQ(s.sampler.num_iterations, 1500);
  EXPECT_EQ(s.sampler.burn_in, 70);
  EXPECT_EQ(s.sampler.hill_climb_steps, 100);
  EXPECT_EQ(s.sampler.hill_climb_patience, 50);
  EXPECT_EQ(s.sampler.hill_climb_max_steps, 2000);
  EXPECT_EQ(s.sampler.refine_every, 50);
  EXPECT_EQ(s.sampler.num_chains, 3);
  EXPECT_EQ(s.sampler.delta_temperature, 0.5);
  EXPECT_EQ(s.sampler.hill_climb_sweeps, 5);
  EXPECT_EQ(s.sampler.hill_climb_moves.merge, sampler.hill_climb_moves.merge);
  EXPECT_EQ(s.sampler.hill_climb_moves.split, sampler.hill_climb_moves.split);
  EXPECT_EQ(s.sampler.sampling_moves.merge, 0.4);
  EXPECT_EQ(s.sampler.sampling_moves.switch_class, 0.2);
  EXPECT_EQ(s.sampler.moves.merge_distance_m, 0.5);
  EXPECT_EQ(s.sampler.moves.merge_sigma_m, 0.5);
  EXPECT_EQ(s.sampler.moves.class_mismatch_penalty, 3.0);
  EXPECT_EQ(s.sampler.moves.merge_count_smoothing, 0.1);
  EXPECT_EQ(s.sampler.moves.class_proposal_uniform, 0.1);
  EXPECT_FALSE(s.sampler.moves.merge_count_includes_self);
  EXPECT_EQ(s.sampler.moves.split_sampler, SplitSampler::kUniform);
  // docs/method.md §9.8: E = 30 px, t0 = (0.4 m)^2, tau = (0.2 m)^2, eq. 6.1 gates.
  EXPECT_EQ(s.target.slam.pixel_std_px, 30.0);
  EXPECT_EQ(s.fusion.spurious_t0_m2, 0.16);
  EXPECT_EQ(s.fusion.spurious_tau_m2, 0.04);
  EXPECT_TRUE(s.fusion.spurious_model);
  EXPECT_EQ(s.tracks.max_radius_change_px, 30.0);
  EXPECT_NEAR(s.tracks.max_angle_change_rad, 20.0 * M_PI / 180.0, 1e-6);
  EXPECT_EQ(s.tracks.max_relative_size_change, 0.2);
  EXPECT_EQ(s.tracks.min_length, 3);
  EXPECT_EQ(s.tracks.link_rule, TrackLinkRule::kNearest);
  EXPECT_EQ(s.tracks.max_gap_frames, 2);  // oslam's occlusion bridging (docs/method.md §9.7)
  // docs/method.md §13 #1: Q_add = diag(5 mm, 5 mm, 1 deg), Q_mult = diag(0.1, 0.01, 0.15), std
  // devs.
  const MotionNoiseOptions& q = s.target.slam.motion;
  EXPECT_EQ(q.additive_std[0], 0.005);
  EXPECT_EQ(q.additive_std[1], 0.005);
  EXPECT_DOUBLE_EQ(q.additive_std[2], M_PI / 180.0);
  EXPECT_EQ(q.multiplicative[0], 0.1);
  EXPECT_EQ(q.multiplicative[1], 0.01);
  EXPECT_EQ(q.multiplicative[2], 0.15);
  EXPECT_FALSE(q.entries_are_variances || q.heading_scales_with_distance || q.world_frame);
  EXPECT_EQ(s.target.proposal_iterations, 1);
  EXPECT_FALSE(s.target.class_prior_per_object);
  EXPECT_EQ(s.target.slam.solver.max_iterations, SolverOptions().max_iterations);
  EXPECT_EQ(s.target.slam.solver.step_tolerance, SolverOptions().step_tolerance);
  EXPECT_TRUE(s.fusion.merge_identities);
  EXPECT_EQ(s.fusion.identity_merge_distance_m, 0.5);
  EXPECT_EQ(s.fusion.identity_class_mismatch_penalty, 3.0);
  EXPECT_EQ(s.fusion.identity_max_cooccurrence, 0.1);
  EXPECT_EQ(s.baseline.gate_m, 0.5);
  EXPECT_EQ(s.confusion_floor, 1e-3);
  EXPECT_EQ(s.location_std_xy_m, 10.0);
  EXPECT_EQ(s.location_std_z_m, 2.0);
  EXPECT_FALSE(s.known_classes);
}

// Every parameter `oslam slam` takes has a configuration key, so nothing is
// settable on the single command but not in `oslam run`.
TEST(RunConfig, EveryOslamSlamParameterHasAKey) {
  SlamStageOptions options;
  Bindings slam;
  BindSlamOptions(&options, &slam);
  size_t flags = 0;
  for (const Binding& binding : slam.entries()) {
    if (binding.flag().empty()) continue;
    ++flags;
    // Not parameters: the baseline is slam.method, the threading changes no result.
    if (binding.flag() == "baseline" || binding.flag() == "sequential") continue;
    EXPECT_FALSE(binding.key().empty()) << "--" << binding.flag() << " has no slam.* key";
  }
  EXPECT_GE(flags, 40u);
}

TEST(RunConfig, AnOverrideReachesTheOptionsTheSamplerGets) {
  struct Case {
    std::string assignment;
    std::function<bool(const SlamStageOptions&)> applied;
  };
  const std::vector<Case> cases = {
      {"slam.pixel_noise_px=15",
       [](const SlamStageOptions& s) { return s.target.slam.pixel_std_px == 15; }},
      {"slam.motion_add_fwd_m=0.02",
       [](const SlamStageOptions& s) { return s.target.slam.motion.additive_std[0] == 0.02; }},
      {"slam.motion_mult_heading=0.3",
       [](const SlamStageOptions& s) { return s.target.slam.motion.multiplicative[2] == 0.3; }},
      {"slam.motion_noise_is_variance=1",
       [](const SlamStageOptions& s) { return s.target.slam.motion.entries_are_variances; }},
      {"slam.spurious_t0_m2=0.25",
       [](const SlamStageOptions& s) { return s.fusion.spurious_t0_m2 == 0.25; }},
      {"slam.spurious_tau_m2=0.01",
       [](const SlamStageOptions& s) { return s.fusion.spurious_tau_m2 == 0.01; }},
      {"slam.spurious_model=0", [](const SlamStageOptions& s) { return !s.fusion.spurious_model; }},
      {"slam.identity_merge=0",
       [](const SlamStageOptions& s) { return !s.fusion.merge_identities; }},
      {"slam.track_gate_radius_px=12",
       [](const SlamStageOptions& s) { return s.tracks.max_radius_change_px == 12; }},
      {"slam.track_gate_angle_rad=0.1",
       [](const SlamStageOptions& s) { return s.tracks.max_angle_change_rad == 0.1; }},
      {"slam.track_gate_size_change=0.3",
       [](const SlamStageOptions& s) { return s.tracks.max_relative_size_change == 0.3; }},
      {"slam.track_link_rule=refuse-ambiguous",
       [](const SlamStageOptions& s) {
         return s.tracks.link_rule == TrackLinkRule::kRefuseAmbiguous;
       }},
      {"slam.merge_sigma_m=0.8",
       [](const SlamStageOptions& s) { return s.sampler.moves.merge_sigma_m == 0.8; }},
      {"slam.split_sampler=thesis",
       [](const SlamStageOptions& s) {
         return s.sampler.moves.split_sampler == SplitSampler::kThesis;
       }},
      {"slam.sampling_moves=0.5,0.3,0.2",
       [](const SlamStageOptions& s) { return s.sampler.sampling_moves.split == 0.3; }},
      {"slam.refine_every=7",
       [](const SlamStageOptions& s) { return s.sampler.refine_every == 7; }},
      {"slam.hill_climb_patience=0",
       [](const SlamStageOptions& s) { return s.sampler.hill_climb_patience == 0; }},
      {"slam.hill_climb_max=700",
       [](const SlamStageOptions& s) { return s.sampler.hill_climb_max_steps == 700; }},
      {"slam.class_proposal_uniform=0",
       [](const SlamStageOptions& s) { return s.sampler.moves.class_proposal_uniform == 0.0; }},
      {"slam.solver_iterations=9",
       [](const SlamStageOptions& s) { return s.target.slam.solver.max_iterations == 9; }},
      {"slam.confusion_floor=0.01",
       [](const SlamStageOptions& s) { return s.confusion_floor == 0.01; }},
      {"slam.nn_gate_m=0.8", [](const SlamStageOptions& s) { return s.baseline.gate_m == 0.8; }},
      {"slam.known_classes=1",
       [](const SlamStageOptions& s) {
         const SamplerOptions sampler = s.EffectiveSampler();
         return s.known_classes && sampler.sampling_moves.merge == 0.5 &&
                sampler.sampling_moves.switch_class == 0 &&
                std::isinf(sampler.moves.class_mismatch_penalty);
       }},
  };
  const RunConfig default_config;
  const SlamStageOptions& defaults = SettingsOf(default_config);
  for (const Case& c : cases) {
    EXPECT_FALSE(c.applied(defaults)) << c.assignment << " is already the default";
    RunConfig config;
    config.Override(c.assignment);
    EXPECT_NO_THROW(config.Check()) << c.assignment;
    EXPECT_TRUE(c.applied(SettingsOf(config))) << c.assignment;
  }
}

TEST(RunConfig, LookAlikeAndShapeGateKeysReachTheDetectStage) {
  const RunConfig defaults;
  EXPECT_TRUE(defaults.options().detect.detector.separate_look_alikes);
  EXPECT_EQ(defaults.Find("detect", "keep_look_alikes")->Value(), "0");
  EXPECT_EQ(defaults.Find("detect", "max_shape_distance")->Value(), "inf");
  RunConfig config;
  config.Override("detect.keep_look_alikes=1");
  config.Override("detect.max_shape_distance=5");
  config.Check();
  EXPECT_FALSE(config.options().detect.detector.separate_look_alikes);
  EXPECT_EQ(config.options().detect.detector.max_shape_distance, 5.0);
  RunConfig bad;
  bad.Override("detect.max_shape_distance=-2");
  EXPECT_THROW(bad.Check(), UsageError);
}

TEST(RunConfig, BadValuesAreOneLineErrorsNamingTheKeyOrFile) {
  RunConfig config;
  const std::string not_number = Message([&] { config.Override("slam.pixel_noise_px=abc"); });
  EXPECT_NE(not_number.find("slam.pixel_noise_px"), std::string::npos) << not_number;
  EXPECT_NE(not_number.find("not a finite number"), std::string::npos) << not_number;
  EXPECT_THROW(config.Override("slam.samples=1.5"), UsageError);
  EXPECT_THROW(config.Override("slam.sampling_moves=0.5,0.5"), UsageError);
  EXPECT_THROW(config.Override("slam.spurious_model=yes"), UsageError);
  EXPECT_THROW(config.Override("slam.nosuch=1"), UsageError);

  // Well-formed but invalid: reported by Check, with the key's name.
  RunConfig invalid;
  invalid.Override("slam.burn_in=2000");
  const std::string burn_in = Message([&] { invalid.Check(); });
  EXPECT_NE(burn_in.find("burn-in"), std::string::npos) << burn_in;
  RunConfig rule;
  const std::string link = Message([&] { rule.Override("slam.track_link_rule=closest"); });
  EXPECT_NE(link.find("slam.track_link_rule must be 'nearest' or 'refuse-ambiguous'"),
            std::string::npos)
      << link;

  testing::TempDir dir;
  std::ofstream(dir.Path("bad.yaml")) << "slam:\n  motion_add_fwd_m: fast\n";
  RunConfig from_file;
  const std::string in_file = Message([&] { from_file.LoadYaml(dir.Path("bad.yaml")); });
  EXPECT_NE(in_file.find("bad.yaml"), std::string::npos) << in_file;
  EXPECT_NE(in_file.find("slam.motion_add_fwd_m"), std::string::npos) << in_file;
  std::ofstream(dir.Path("negative.yaml")) << "slam:\n  merge_sigma_m: -1\n";
  RunConfig negative;
  negative.LoadYaml(dir.Path("negative.yaml"));
  try {
    negative.Check();
    ADD_FAILURE() << "a negative sigma_E passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("negative.yaml"), std::string::npos) << e.what();
  }
  for (const std::string& message : {not_number, burn_in, link, in_file})
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

}  // namespace
}  // namespace oslam
