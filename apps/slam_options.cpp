#include "apps/slam_options.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "core/error.h"

namespace oslam {
namespace {

// Shortest text that reads back as the same double ("0.349066", "1e-08").
std::string Number(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string Triple(const MoveProbabilities& p) {
  return Number(p.merge) + "," + Number(p.split) + "," + Number(p.switch_class);
}

MoveProbabilities GetMoves(const Arguments& arguments, const std::string& name) {
  const std::string text = arguments.Get(name);
  std::stringstream items(text);
  std::string item;
  std::vector<double> values;
  while (std::getline(items, item, ',')) {
    char* end = nullptr;
    const double value = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(value)) {
      values.clear();
      break;
    }
    values.push_back(value);
  }
  if (values.size() != 3)
    throw UsageError("--" + name + ": '" + text +
                     "' is not three probabilities merge,split,switch like 0.4,0.4,0.2");
  return {values[0], values[1], values[2]};
}

}  // namespace

void AddSlamOptions(Arguments* a) {
  const SlamSettings d;  // the mapping code's defaults
  const SamplerOptions& s = d.sampler;
  const MotionNoiseOptions& q = d.target.slam.motion;
  a->AddOption("seed", "", "N", "seed of the sampler", std::to_string(s.seed));
  a->AddOption("samples", "", "N", "MC3 iterations including burn-in (spec §13 #21)",
               std::to_string(s.num_iterations));
  a->AddOption("burn-in", "", "N", "iterations discarded", std::to_string(s.burn_in));
  a->AddOption("hill-climb", "", "N", "hill-climbing steps (the minimum)",
               std::to_string(s.hill_climb_steps));
  a->AddOption("hill-climb-patience", "", "N",
               "then climb on while a move was accepted in the last N steps (0 = fixed count)",
               std::to_string(s.hill_climb_patience));
  a->AddOption("hill-climb-max", "", "N", "at most this many hill-climbing steps",
               std::to_string(s.hill_climb_max_steps));
  a->AddOption("refine-every", "", "N",
               "K_NL: full re-optimisation of the current state every N hill-climbing steps",
               std::to_string(s.refine_every));
  a->AddOption("hill-climb-moves", "", "M,S,W", "merge,split,switch probabilities in hill climbing",
               Triple(s.hill_climb_moves));
  a->AddOption("sampling-moves", "", "M,S,W",
               "merge,split,switch probabilities in MC3 (--known-classes: switch 0, rest rescaled)",
               Triple(s.sampling_moves));
  a->AddOption("chains", "", "N", "MC3 chains (1 = Metropolis-Hastings)",
               std::to_string(s.num_chains));
  a->AddOption("delta-t", "", "DT", "temperature step between chains", Number(s.delta_temperature));
  a->AddOption("baseline", "", "nn", "instead of O-SLAM: gated nearest-neighbour association");
  a->AddOption("nn-gate", "", "M", "nearest-neighbour baseline: 3-D association gate",
               Number(d.baseline.gate_m));
  a->AddOption("min-track-length", "", "N", "drop shorter tracks (Sec. 6.3: 3)",
               std::to_string(d.tracks.min_length));
  a->AddOption("gate-radius", "", "PX", "track linking: largest |du_r| (eq. 6.1)",
               Number(d.tracks.max_radius_change_px));
  a->AddOption("gate-angle", "", "RAD", "track linking: largest |du_phi| (eq. 6.1; 20 deg)",
               Number(d.tracks.max_angle_change_rad));
  a->AddOption("gate-size-change", "", "F",
               "track linking: largest |ds| as a fraction of the smaller size (eq. 6.1)",
               Number(d.tracks.max_relative_size_change));
  a->AddOption("link-rule", "", "nearest|refuse-ambiguous",
               "track linking when several candidates pass the gate (spec §13 #20)", "nearest");
  // Beyond the thesis; 2 is oslam's default, the struct's 0 is the thesis.
  a->AddOption("max-gap", "", "N",
               "join tracks across up to N missed frames (occlusions; 0 = thesis)", "2");
  a->AddFlag("no-identity-merge",
             "keep one map object per sample identity (thesis Algorithm 3 as printed)");
  a->AddOption("identity-distance", "", "M",
               "identities closer than this that rarely co-occur become one object",
               Number(d.fusion.identity_merge_distance_m));
  a->AddOption("identity-mismatch-penalty", "", "X",
               "identity merging: squared-distance factor across classes (inf = never)",
               Number(d.fusion.identity_class_mismatch_penalty));
  a->AddOption("identity-max-cooccurrence", "", "F",
               "identity merging: largest fraction of samples holding both",
               Number(d.fusion.identity_max_cooccurrence));
  a->AddFlag("no-spurious-model", "P(xi) = 1 for every object (spec §7.2 off)");
  a->AddOption("spurious-t0", "", "M2", "spurious sigmoid t0 (spec §7.2: (0.4 m)^2)",
               Number(d.fusion.spurious_t0_m2));
  a->AddOption("spurious-tau", "", "M2", "spurious sigmoid tau (spec §7.2: (0.2 m)^2)",
               Number(d.fusion.spurious_tau_m2));
  a->AddOption("proposal-iterations", "", "N", "solver iterations per proposed state",
               std::to_string(d.target.proposal_iterations));
  a->AddFlag("class-prior-per-object", "P(C, J) = prod_j 1/|classes| instead of uniform (#37)");
  a->AddOption("mismatch-penalty", "", "X", "class-mismatch factor on e_j (inf = never)",
               Number(s.moves.class_mismatch_penalty));
  a->AddOption("merge-distance", "", "M", "merge proposal threshold d_thr",
               Number(s.moves.merge_distance_m));
  a->AddOption("merge-sigma", "", "M", "merge proposal sigma_E (spec §13 #14)",
               Number(s.moves.merge_sigma_m));
  a->AddOption("class-proposal-uniform", "", "U",
               "uniform share of the class drawn by merge/split/switch (0 = thesis)",
               Number(s.moves.class_proposal_uniform));
  a->AddOption("merge-count-smoothing", "", "EPS", "epsilon_d added to every d_j (#16)",
               Number(s.moves.merge_count_smoothing));
  a->AddFlag("merge-count-includes-self", "d_j counts o_j itself (#41)");
  a->AddOption("split-sampler", "", "uniform|thesis", "split partition proposal (#18/#43)",
               "uniform");
  a->AddOption("confusion-floor", "", "P", "smallest P(a | c); rows renormalised",
               Number(d.confusion_floor));
  a->AddOption("location-std-xy", "", "M", "class location prior std, x and y",
               Number(d.location_std_xy_m));
  a->AddOption("location-std-z", "", "M", "class location prior std, z",
               Number(d.location_std_z_m));
  a->AddOption("pixel-noise", "", "PX", "detection noise E (spec §4.2; thesis 30)",
               Number(d.target.slam.pixel_std_px));
  a->AddOption("motion-add-fwd", "", "M", "Q_add forward std (spec §13 #1)",
               Number(q.additive_std[0]));
  a->AddOption("motion-add-lat", "", "M", "Q_add lateral std", Number(q.additive_std[1]));
  a->AddOption("motion-add-heading", "", "RAD", "Q_add heading std (1 deg)",
               Number(q.additive_std[2]));
  a->AddOption("motion-mult-fwd", "", "F", "Q_mult forward, times |v_r|",
               Number(q.multiplicative[0]));
  a->AddOption("motion-mult-lat", "", "F", "Q_mult lateral, times |v_r|",
               Number(q.multiplicative[1]));
  a->AddOption("motion-mult-heading", "", "F", "Q_mult heading, times |v_phi|",
               Number(q.multiplicative[2]));
  a->AddFlag("motion-variances", "read Q_add and Q_mult as variances, not std devs (#2)");
  a->AddFlag("motion-heading-by-distance", "Q_mult heading row scales with |v_r| (#2)");
  a->AddFlag("motion-world-frame", "Q_i in the world frame, not rotated from the robot's (#2)");
  a->AddOption("solver-iterations", "", "N",
               "full optimisation: most Levenberg-Marquardt iterations",
               std::to_string(d.target.slam.solver.max_iterations));
  a->AddOption("solver-step-tolerance", "", "X",
               "full optimisation: converged when max |step| < X (m, rad; spec §5.4)",
               Number(d.target.slam.solver.step_tolerance));
  a->AddFlag("known-classes", "assume perfect classes: no switch moves, P_merge = P_split = 0.5");
  a->AddFlag("sequential", "step the chains one after another (same result as threads)");
  a->AddOption("swap-every", "", "N",
               "MC3: adjacent chains may swap after every N iterations (1 = Algorithm 8); the "
               "chains step independently in between",
               std::to_string(d.sampler.swap_every));
  a->AddOption("speculation-depth", "", "N",
               "MC3 on threads: a chain may run up to N swap intervals ahead of the swap "
               "decisions and goes back when a swap reaches it (0 = lock-step; same result)",
               std::to_string(d.sampler.speculation_depth));
  a->AddOption("hill-climb-screen", "", "NATS",
               "hill climbing: skip the solve when the approximate gain is below -NATS (inf = "
               "solve every proposal)",
               Number(d.sampler.hill_climb_screen_nats));
  a->AddFlag("class-likelihood-per-detection",
             "count log P(a | c) once per detection (eq. 4.32 as printed), not once per track");
  a->AddFlag("no-delayed-acceptance",
             "solve every MC3 proposal (thesis) instead of screening it first with the changed "
             "objects solved alone");
}

SlamSettings SlamSettingsFrom(const Arguments& arguments) {
  auto integer = [&](const char* name) { return static_cast<int>(arguments.GetInt(name)); };
  auto number = [&](const char* name) { return arguments.GetDouble(name); };
  SlamSettings s;
  if (arguments.GetInt("seed") < 0) throw UsageError("--seed must be >= 0");
  s.known_classes = arguments.Flag("known-classes");
  s.class_likelihood_per_detection = arguments.Flag("class-likelihood-per-detection");

  TrackOptions& t = s.tracks;
  t.min_length = integer("min-track-length");
  t.max_gap_frames = integer("max-gap");
  t.max_radius_change_px = number("gate-radius");
  t.max_angle_change_rad = number("gate-angle");
  t.max_relative_size_change = number("gate-size-change");
  const std::string rule = arguments.Get("link-rule");
  if (rule == "nearest") {
    t.link_rule = TrackLinkRule::kNearest;
  } else if (rule == "refuse-ambiguous") {
    t.link_rule = TrackLinkRule::kRefuseAmbiguous;
  } else {
    throw UsageError("--link-rule must be 'nearest' or 'refuse-ambiguous', not '" + rule + "'");
  }

  FusionOptions& f = s.fusion;
  f.merge_identities = !arguments.Flag("no-identity-merge");
  f.identity_merge_distance_m = number("identity-distance");
  f.identity_class_mismatch_penalty = arguments.GetDoubleOrInfinity("identity-mismatch-penalty");
  f.identity_max_cooccurrence = number("identity-max-cooccurrence");
  f.spurious_model = !arguments.Flag("no-spurious-model");
  f.spurious_t0_m2 = number("spurious-t0");
  f.spurious_tau_m2 = number("spurious-tau");

  SlamTargetOptions& target = s.target;
  target.proposal_iterations = integer("proposal-iterations");
  target.class_prior_per_object = arguments.Flag("class-prior-per-object");
  GeometricSlamOptions& g = target.slam;
  g.pixel_std_px = number("pixel-noise");
  g.motion.additive_std = {number("motion-add-fwd"), number("motion-add-lat"),
                           number("motion-add-heading")};
  g.motion.multiplicative = {number("motion-mult-fwd"), number("motion-mult-lat"),
                             number("motion-mult-heading")};
  g.motion.entries_are_variances = arguments.Flag("motion-variances");
  g.motion.heading_scales_with_distance = arguments.Flag("motion-heading-by-distance");
  g.motion.world_frame = arguments.Flag("motion-world-frame");
  g.solver.max_iterations = integer("solver-iterations");
  g.solver.step_tolerance = number("solver-step-tolerance");

  SamplerOptions& sampler = s.sampler;
  sampler.seed = static_cast<unsigned long>(arguments.GetInt("seed"));
  sampler.num_iterations = integer("samples");
  sampler.burn_in = integer("burn-in");
  sampler.hill_climb_steps = integer("hill-climb");
  sampler.hill_climb_patience = integer("hill-climb-patience");
  sampler.hill_climb_max_steps = integer("hill-climb-max");
  sampler.refine_every = integer("refine-every");
  sampler.hill_climb_moves = GetMoves(arguments, "hill-climb-moves");
  sampler.sampling_moves = GetMoves(arguments, "sampling-moves");
  sampler.num_chains = integer("chains");
  sampler.delta_temperature = number("delta-t");
  sampler.parallel_chains = !arguments.Flag("sequential");
  sampler.delayed_acceptance = !arguments.Flag("no-delayed-acceptance");
  sampler.swap_every = integer("swap-every");
  sampler.speculation_depth = integer("speculation-depth");
  sampler.hill_climb_screen_nats = arguments.GetDoubleOrInfinity("hill-climb-screen");
  MoveOptions& m = sampler.moves;
  m.class_mismatch_penalty = arguments.GetDoubleOrInfinity("mismatch-penalty");
  m.merge_distance_m = number("merge-distance");
  m.merge_sigma_m = number("merge-sigma");
  m.merge_count_smoothing = number("merge-count-smoothing");
  m.class_proposal_uniform = number("class-proposal-uniform");
  m.merge_count_includes_self = arguments.Flag("merge-count-includes-self");
  const std::string split = arguments.Get("split-sampler");
  if (split == "uniform") {
    m.split_sampler = SplitSampler::kUniform;
  } else if (split == "thesis") {
    m.split_sampler = SplitSampler::kThesis;
  } else {
    throw UsageError("--split-sampler must be 'uniform' or 'thesis', not '" + split + "'");
  }
  if (s.known_classes) {
    // Sec. 6.2: no switch moves (0.4/0.4/0.2 becomes 0.5/0.5/0), never merge across classes.
    MoveProbabilities& p = sampler.sampling_moves;
    const double rest = p.merge + p.split;
    if (rest > 0) p = {p.merge / rest, p.split / rest, 0.0};
    m.class_mismatch_penalty = std::numeric_limits<double>::infinity();
  }

  s.baseline.gate_m = number("nn-gate");
  s.confusion_floor = number("confusion-floor");
  if (!(s.confusion_floor > 0 && s.confusion_floor < 1))
    throw UsageError("--confusion-floor must be in (0, 1)");
  s.location_std_xy_m = number("location-std-xy");
  s.location_std_z_m = number("location-std-z");
  if (!(s.location_std_xy_m > 0) || !(s.location_std_z_m > 0))
    throw UsageError("--location-std-xy and --location-std-z must be > 0 m");

  std::string why;
  if (!t.Validate(&why) || !target.Validate(&why) || !f.Validate(&why) || !sampler.Validate(&why) ||
      !s.baseline.Validate(&why))
    throw UsageError(why);
  return s;
}

}  // namespace oslam
