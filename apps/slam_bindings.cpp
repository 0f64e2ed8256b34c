// The O-SLAM parameters: `oslam slam` (and `oslam map`'s O-SLAM mode) flags
// and `oslam run`'s slam section, in the order of the configuration file.
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

#include "apps/stage_bindings.h"
#include "core/text.h"

namespace oslam {
namespace {

// "merge,split,switch[,reassign]" probabilities, e.g. 0.4,0.4,0.2 or
// 0.3,0.3,0.2,0.2 (reassign 0 when left out).
Binding& AddMoves(MoveProbabilities* p, const std::string& flag, const std::string& help,
                  Bindings* b) {
  auto get = [p] {
    std::string text = Number(p->merge) + "," + Number(p->split) + "," + Number(p->switch_class);
    return p->reassign != 0 ? text + "," + Number(p->reassign) : text;
  };
  auto set = [p](const std::string& text) -> std::string {
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
    if (values.size() != 3 && values.size() != 4)
      return ": '" + text +
             "' is not three or four probabilities merge,split,switch[,reassign] like "
             "0.4,0.4,0.2";
    *p = {values[0], values[1], values[2], values.size() == 4 ? values[3] : 0.0};
    return "";
  };
  return b->AddCustom(flag, "M,S,W[,R]", help, get, set).Quoted();
}

// Method, seed and the sampler's schedule.
void BindSampling(SlamStageOptions* o, Bindings* b) {
  SamplerOptions& s = o->sampler;
  b->AddChoice(&o->method, {{"oslam", SlamMethod::kOSlam}, {"nn", SlamMethod::kNearestNeighbour}},
               "", "", "")
      .Key("method", "oslam (MCMC over association and classes) or nn (baseline)");
  b->AddCustom(
       "baseline", "nn", "instead of O-SLAM: gated nearest-neighbour association",
       [] { return std::string(); },
       [o](const std::string& text) -> std::string {
         if (text != "nn") return " takes 'nn' (nearest neighbour)";
         o->method = SlamMethod::kNearestNeighbour;
         return "";
       })
      .ShowDefault("");
  b->Add(&s.seed, "seed", "N", "seed of the sampler")
      .Key("seed", "seed of every random choice of the sampler");
  b->Add(&s.num_iterations, "samples", "N",
         "MC3 iterations including burn-in (docs/method.md §13 #21)")
      .Key("samples", "MC3 iterations incl. burn-in (docs/method.md §9.8, §13 #21)");
  b->Add(&s.burn_in, "burn-in", "N", "iterations discarded")
      .Key("burn_in", "iterations discarded (docs/method.md §9.8)");
  b->Add(&s.hill_climb_steps, "hill-climb", "N", "hill-climbing steps (the minimum)")
      .Key("hill_climb", "hill-climbing steps, the minimum (docs/method.md §9.7)");
  b->Add(&s.hill_climb_patience, "hill-climb-patience", "N",
         "then climb on while a move was accepted in the last N steps (0 = fixed count)")
      .Key("hill_climb_patience");
  b->Add(&s.hill_climb_max_steps, "hill-climb-max", "N", "at most this many hill-climbing steps")
      .Key("hill_climb_max");
  b->Add(&s.hill_climb_sweeps, "hill-climb-sweeps", "N",
         "then at most N sweeps trying every single-track move and class switch (0 = thesis)")
      .Key("hill_climb_sweeps",
           "then at most N sweeps of every single-track move and class switch (docs/method.md "
           "§9.7)");
  b->Add(&s.refine_every, "refine-every", "N",
         "K_NL: full re-optimisation of the current state every N hill-climbing steps")
      .Key("refine_every",
           "K_NL: full re-optimisation every N hill-climbing steps (docs/method.md §9.7)");
  AddMoves(&s.hill_climb_moves, "hill-climb-moves",
           "merge,split,switch[,reassign] probabilities in hill climbing", b)
      .Key("hill_climb_moves",
           "merge,split,switch[,reassign] probabilities in hill climbing (docs/method.md §9.8)");
  AddMoves(&s.sampling_moves, "sampling-moves",
           "merge,split,switch[,reassign] probabilities in MC3 (--known-classes: switch 0, rest "
           "rescaled)",
           b)
      .Key("sampling_moves",
           "merge,split,switch[,reassign] probabilities in MC3; known_classes: switch 0, rest "
           "rescaled");
  b->Add(&s.num_chains, "chains", "N", "MC3 chains (1 = Metropolis-Hastings)")
      .Key("chains", "MC3 chains, 1 = Metropolis-Hastings (docs/method.md §9.4)");
  b->Add(&s.cold_chain_steps, "cold-chain-steps", "K",
         "Metropolis-Hastings steps of the cold chain per MC3 iteration (1 = thesis)")
      .Key("cold_chain_steps",
           "steps of the cold chain per MC3 iteration, 1 = thesis (docs/method.md §9.4)");
  b->Add(&s.track_scan_max, "track-scan", "N",
         "MC3's cold chain also updates up to N contested tracks each iteration (0 = off)")
      .Key("track_scan",
           "cold chain: update up to N contested tracks in turn each MC3 iteration, 0 = off "
           "(docs/method.md §9.4)");
  b->Add(&s.track_scan_nats, "track-scan-nats", "NATS",
         "a track is contested when one change of it is within NATS of the hill-climbed state")
      .Key("track_scan_nats",
           "track scan: contested when a single change is within this many nats (approximate)");
  b->Add(&s.delta_temperature, "delta-t", "DT", "temperature step between chains")
      .Key("delta_t", "temperature step between chains (docs/method.md §9.4)");
  b->AddFlag(&o->known_classes, "known-classes",
             "assume perfect classes: no switch moves, P_merge = P_split = 0.5")
      .Key("known_classes",
           "1: detected classes are right (no switch moves, no merges across classes; Sec. 6.2)");
}

// Track pre-association (eq. 6.1).
void BindTracks(SlamStageOptions* o, Bindings* b) {
  TrackOptions& t = o->tracks;
  b->Add(&t.min_length, "min-track-length", "N", "drop shorter tracks (Sec. 6.3: 3)")
      .Key("min_track_length", "drop tracks with fewer detections (docs/method.md §6.3, §9.8)");
  b->Add(&t.max_radius_change_px, "gate-radius", "PX", "track linking: largest |du_r| (eq. 6.1)")
      .Key("track_gate_radius_px", "track pre-association: largest |du_r|, px (eq. 6.1)");
  b->Add(&t.max_angle_change_rad, "gate-angle", "RAD",
         "track linking: largest |du_phi| (eq. 6.1; 20 deg)")
      .Key("track_gate_angle_rad",
           "track pre-association: largest |du_phi|, rad (eq. 6.1: 20 deg, §13 #20)");
  b->Add(&t.max_relative_size_change, "gate-size-change", "F",
         "track linking: largest |ds| as a fraction of the smaller size (eq. 6.1)")
      .Key("track_gate_size_change",
           "track pre-association: largest |ds_r|, |ds_phi| as a fraction of the smaller (eq. "
           "6.1)");
  b->AddChoice(&t.link_rule,
               {{"nearest", TrackLinkRule::kNearest},
                {"refuse-ambiguous", TrackLinkRule::kRefuseAmbiguous}},
               "link-rule", "nearest|refuse-ambiguous",
               "track linking when several candidates pass the gate (docs/method.md §13 #20)")
      .Key("track_link_rule",
           "nearest (one-to-one, closest first) or refuse-ambiguous (docs/method.md §13 #20)");
  b->Add(&t.max_gap_frames, "max-gap", "N",
         "join tracks across up to N missed frames (occlusions; 0 = thesis)")
      .Key("track_max_gap_frames");
}

// The proposals: solver iterations, class prior, merge and split moves.
void BindProposals(SlamStageOptions* o, Bindings* b) {
  MoveOptions& m = o->sampler.moves;
  b->Add(&o->target.proposal_iterations, "proposal-iterations", "N",
         "solver iterations per proposed state")
      .Key("proposal_iterations",
           "solver iterations per proposed state (docs/method.md §9.6, §13 #46)");
  b->AddNegatedFlag(&o->target.linearise_at_reference, "linearise-at-current",
                    "solve each proposal from the current state (thesis) instead of the "
                    "hill-climbed one")
      .Key("linearise_at_reference",
           "1: MC3 solves each proposal from the hill-climbed solution, so a state's value "
           "does not depend on its path; 0: from the current state (docs/method.md §9.6)");
  b->AddFlag(&o->target.class_prior_per_object, "class-prior-per-object",
             "P(C, J) = prod_j 1/|classes| instead of uniform (#37)")
      .Key("class_prior_per_object",
           "1: P(C, J) = prod_j 1/|classes|; 0: uniform joint (docs/method.md §13 #13/#37)");
  b->AddNumberOrInfinity(&m.class_mismatch_penalty, "mismatch-penalty", "X",
                         "class-mismatch factor on e_j (inf = never)")
      .Key("mismatch_penalty",
           "class-mismatch factor in the merge proposal, inf = never (docs/method.md §13 #15)");
  b->Add(&m.merge_distance_m, "merge-distance", "M", "merge proposal threshold d_thr")
      .Key("merge_distance_m", "merge proposal distance threshold d_thr, m (docs/method.md §9.8)");
  b->Add(&m.merge_sigma_m, "merge-sigma", "M", "merge proposal sigma_E (docs/method.md §13 #14)")
      .Key("merge_sigma_m", "merge proposal sigma_E, m (docs/method.md §13 #14)");
  b->Add(&m.reassign_sigma_m, "reassign-sigma", "M",
         "reassign move sigma_R: how far a track looks for an object (docs/method.md §9.2)")
      .Key("reassign_sigma_m", "reassign move sigma_R, m (docs/method.md §9.2)");
  b->Add(&m.reassign_focus, "reassign-focus", "K",
         "reassign picks tracks misfitting their object's class or alone 1+K times as often")
      .Key("reassign_focus",
           "reassign: weight 1 + K of a track misfitting its object's class or alone "
           "(docs/method.md §9.2)");
  b->Add(&m.class_proposal_uniform, "class-proposal-uniform", "U",
         "uniform share of the class drawn by merge/split/switch (0 = thesis)")
      .Key("class_proposal_uniform");
  b->Add(&m.merge_count_smoothing, "merge-count-smoothing", "EPS",
         "epsilon_d added to every d_j (#16)")
      .Key("merge_count_smoothing", "epsilon_d added to every d_j (docs/method.md §13 #16)");
  b->AddFlag(&m.merge_count_includes_self, "merge-count-includes-self",
             "d_j counts o_j itself (#41)")
      .Key("merge_count_includes_self", "1: d_j counts o_j itself (docs/method.md §13 #41)");
  b->AddChoice(&m.split_sampler,
               {{"uniform", SplitSampler::kUniform},
                {"thesis", SplitSampler::kThesis},
                {"one-or-uniform", SplitSampler::kOneTrackOrUniform}},
               "split-sampler", "uniform|thesis|one-or-uniform",
               "split partition proposal (#18/#43)")
      .Key("split_sampler",
           "uniform (non-empty subset), thesis (Algorithm 6) or one-or-uniform (one track alone "
           "half the time) (docs/method.md §9.2, §13 #18/#43)");
}

// The model: class confusion and priors, detection and odometry noise, the solver.
void BindModel(SlamStageOptions* o, Bindings* b) {
  GeometricSlamOptions& g = o->target.slam;
  MotionNoiseOptions& q = g.motion;
  b->Add(&o->confusion_floor, "confusion-floor", "P", "smallest P(a | c); rows renormalised")
      .Key("confusion_floor",
           "smallest class confusion probability P(a | c); rows renormalised (docs/method.md §13 "
           "#12)")
      .Check([o] { return o->confusion_floor > 0 && o->confusion_floor < 1; }, "must be in (0, 1)");
  b->Add(&o->location_std_xy_m, "location-std-xy", "M", "class location prior std, x and y")
      .Key("location_std_xy_m", "class location prior std in x and y, m (docs/method.md §13 #7)")
      .Check([o] { return o->location_std_xy_m > 0; }, "must be > 0 m");
  b->Add(&o->location_std_z_m, "location-std-z", "M", "class location prior std, z")
      .Key("location_std_z_m", "class location prior std in z, m (docs/method.md §13 #7)")
      .Check([o] { return o->location_std_z_m > 0; }, "must be > 0 m");
  b->AddNegatedFlag(&o->silhouette_model, "no-silhouette",
                    "predict the cylinder's section (thesis) instead of the class's silhouette")
      .Key("silhouette_model",
           "1: detections predicted as the class's silhouette (classes.yaml shape; "
           "docs/method.md §4.2)");
  b->AddNegatedFlag(&o->censor_slices, "no-censoring",
                    "slice ends cut by the image's limits count as values (thesis)")
      .Key("censor_slices",
           "1: slice ends at the mirror rim, blind disc or image border are bounds "
           "(docs/method.md §4.2)");
  b->Add(&o->censor_margin_px, "censor-margin", "PX",
         "a slice end this close to an image limit is a bound")
      .Key("censor_margin_px", "a slice end this close to an image limit is a bound, px")
      .Check([o] { return o->censor_margin_px >= 0; }, "must be >= 0 px");
  b->AddNegatedFlag(&o->support_prior, "no-support-prior",
                    "base height from location-std-z for every class (thesis)")
      .Key("support_prior",
           "1: base height from the class's support prior (classes.yaml base_height_m, "
           "base_height_std_m; docs/method.md §5.1)");
  b->Add(&o->bearing_noise_px, "bearing-noise", "PX",
         "bearing noise E_phi: sigma(u_phi) = E_phi / u_r (0: E, thesis)")
      .Key("bearing_noise_px",
           "bearing noise E_phi, px: sigma(u_phi) = E_phi / u_r; 0: the detection noise E "
           "(thesis; docs/method.md §4.2)")
      .Check([o] { return o->bearing_noise_px >= 0; }, "must be >= 0 px");
  b->Add(&g.pixel_std_px, "pixel-noise", "PX", "detection noise E (docs/method.md §4.2; thesis 30)")
      .Key("pixel_noise_px",
           "detection noise E, px: R = diag(E^2, (E/u_r)^2) (docs/method.md §4.2, §13 #5)");
  b->Add(&q.additive_std[0], "motion-add-fwd", "M", "Q_add forward std (docs/method.md §13 #1)")
      .Key("motion_add_fwd_m",
           "odometry noise Q_add, forward std, m (docs/method.md §4.1, §13 #1)");
  b->Add(&q.additive_std[1], "motion-add-lat", "M", "Q_add lateral std")
      .Key("motion_add_lat_m", "odometry noise Q_add, lateral std, m");
  b->Add(&q.additive_std[2], "motion-add-heading", "RAD", "Q_add heading std (1 deg)")
      .Key("motion_add_heading_rad", "odometry noise Q_add, heading std, rad (1 deg)");
  b->Add(&q.multiplicative[0], "motion-mult-fwd", "F", "Q_mult forward, times |v_r|")
      .Key("motion_mult_fwd", "odometry noise Q_mult, forward, times |v_r|");
  b->Add(&q.multiplicative[1], "motion-mult-lat", "F", "Q_mult lateral, times |v_r|")
      .Key("motion_mult_lat", "odometry noise Q_mult, lateral, times |v_r|");
  b->Add(&q.multiplicative[2], "motion-mult-heading", "F", "Q_mult heading, times |v_phi|")
      .Key("motion_mult_heading", "odometry noise Q_mult, heading, times |v_phi|");
  b->AddFlag(&q.entries_are_variances, "motion-variances",
             "read Q_add and Q_mult as variances, not std devs (#2)")
      .Key("motion_noise_is_variance",
           "1: read Q_add and Q_mult as variances instead of std devs (docs/method.md §13 #2)");
  b->AddFlag(&q.heading_scales_with_distance, "motion-heading-by-distance",
             "Q_mult heading row scales with |v_r| (#2)")
      .Key("motion_heading_by_distance",
           "1: the heading row of Q_mult scales with |v_r| instead of |v_phi| (docs/method.md §13 "
           "#2)");
  b->AddFlag(&q.world_frame, "motion-world-frame",
             "Q_i in the world frame, not rotated from the robot's (#2)")
      .Key("motion_world_frame",
           "1: Q_i in the world frame, not rotated from the robot frame (docs/method.md §13 #2)");
  b->Add(&g.solver.max_iterations, "solver-iterations", "N",
         "full optimisation: most Levenberg-Marquardt iterations")
      .Key("solver_iterations",
           "full optimisation: most Levenberg-Marquardt iterations (docs/method.md §5.4, §13 #8)");
  b->Add(&g.solver.step_tolerance, "solver-step-tolerance", "X",
         "full optimisation: converged when max |step| < X (m, rad; docs/method.md §5.4)")
      .Key("solver_step_tolerance",
           "full optimisation: converged when max |step| < this, m and rad (docs/method.md §5.4)");
}

// Existence (spurious model), the MC3 schedule on threads, identity merging
// and the baseline's gate.
void BindFusionAndSchedule(SlamStageOptions* o, Bindings* b) {
  FusionOptions& f = o->fusion;
  SamplerOptions& s = o->sampler;
  b->AddNegatedFlag(&f.spurious_model, "no-spurious-model",
                    "P(xi) = 1 for every object (docs/method.md §7.2 off)")
      .Key("spurious_model",
           "1: existence weighted by P(xi), the spurious-object sigmoid (docs/method.md §7.2)");
  b->Add(&f.spurious_t0_m2, "spurious-t0", "M2",
         "spurious sigmoid t0 (docs/method.md §7.2: (0.4 m)^2)")
      .Key("spurious_t0_m2", "spurious sigmoid t0, m^2: (0.4 m)^2 (docs/method.md §7.2, §9.8)");
  b->Add(&f.spurious_tau_m2, "spurious-tau", "M2",
         "spurious sigmoid tau (docs/method.md §7.2: (0.2 m)^2)")
      .Key("spurious_tau_m2", "spurious sigmoid tau, m^2: (0.2 m)^2 (docs/method.md §7.2, §9.8)");
  b->AddNegatedFlag(&f.class_geometry_evidence, "no-class-geometry-evidence",
                    "P(xi) from the location uncertainty alone (docs/method.md §7.2, thesis), "
                    "not also from how well the geometry fits the class")
      .Key("class_geometry_evidence",
           "1: P(xi)'s odds times the Bayes factor of the geometry under the class against a "
           "look-alike (docs/method.md §7.2)");
  b->AddFlag(&f.existence_given_class, "existence-given-class",
             "the spurious sigmoid keeps the class's size and base-height priors and removes only "
             "the horizontal location prior (docs/method.md §7.2)")
      .Key("existence_given_class",
           "1: the spurious sigmoid keeps the class's size and base-height priors (docs/method.md "
           "§7.2)");
  b->Add(&f.lookalike_size_std_m, "lookalike-size-std", "M",
         "spread of a look-alike's diameter and height about the class's (docs/method.md §7.2)")
      .Key("lookalike_size_std_m", "spread of a look-alike's diameter and height, m");
  b->Add(&f.lookalike_base_std_m, "lookalike-base-std", "M",
         "least spread of a look-alike's base height (docs/method.md §7.2)")
      .Key("lookalike_base_std_m", "least spread of a look-alike's base height, m");
  b->Add(&f.lookalike_prior, "lookalike-prior", "P",
         "prior probability that a consistently detected object is a look-alike of its class "
         "(docs/method.md §7.2)")
      .Key("lookalike_prior", "prior probability of a look-alike, in (0, 1) (docs/method.md §7.2)")
      .Check([o] { return o->fusion.lookalike_prior > 0 && o->fusion.lookalike_prior < 1; },
             "must be in (0, 1)");
  b->AddFlag(&o->class_likelihood_per_detection, "class-likelihood-per-detection",
             "count log P(a | c) once per detection (eq. 4.32 as printed), not once per track")
      .Key("class_likelihood_per_detection",
           "1: log P(a | c) once per detection (eq. 4.32), 0: once per track");
  b->Add(&s.swap_every, "swap-every", "N",
         "MC3: adjacent chains may swap after every N iterations (1 = Algorithm 8); the chains "
         "step independently in between")
      .Key("swap_every", "MC3: chains may swap after every this many iterations (1 = thesis)");
  b->Add(&s.speculation_depth, "speculation-depth", "N",
         "MC3 on threads: a chain may run up to N swap intervals ahead of the swap decisions "
         "and goes back when a swap reaches it (0 = lock-step; same result)")
      .Key("speculation_depth",
           "MC3 on threads: swap intervals a chain may run ahead (0 = lock-step; same result)");
  b->AddNegatedFlag(&s.parallel_chains, "sequential",
                    "step the chains one after another (same result as threads)");
  b->AddNumberOrInfinity(&s.hill_climb_screen_nats, "hill-climb-screen", "NATS",
                         "hill climbing: skip the solve when the approximate gain is below "
                         "-NATS (inf = solve every proposal)")
      .Key("hill_climb_screen_nats",
           "hill climbing: no solve when the approximate gain is below -this, inf = always solve");
  b->AddNegatedFlag(&s.delayed_acceptance, "no-delayed-acceptance",
                    "solve every MC3 proposal (thesis) instead of screening it first with the "
                    "changed objects solved alone")
      .Key(
          "delayed_acceptance",
          "1: MC3 proposals screened before they are solved, same posterior (docs/method.md §9.3)");
  b->AddNegatedFlag(&f.merge_identities, "no-identity-merge",
                    "keep one map object per sample identity (thesis Algorithm 3 as printed)")
      .Key("identity_merge",
           "1: combine sample identities of one object (beyond the thesis, docs/method.md §7.3)");
  b->Add(&f.identity_merge_distance_m, "identity-distance", "M",
         "identities closer than this that rarely co-occur become one object")
      .Key("identity_distance_m", "identity merging: largest distance of combined identities, m");
  b->AddNumberOrInfinity(&f.identity_class_mismatch_penalty, "identity-mismatch-penalty", "X",
                         "identity merging: squared-distance factor across classes (inf = never)")
      .Key("identity_mismatch_penalty",
           "identity merging: squared-distance factor across classes, inf = never");
  b->Add(&f.identity_max_cooccurrence, "identity-max-cooccurrence", "F",
         "identity merging: largest fraction of samples holding both")
      .Key("identity_max_cooccurrence",
           "identity merging: largest fraction of the rarer identity's samples holding both");
  b->Add(&o->baseline.gate_m, "nn-gate", "M", "nearest-neighbour baseline: 3-D association gate")
      .Key("nn_gate_m", "method nn: nearest-neighbour association gate, m");
}

}  // namespace

void BindSlamOptions(SlamStageOptions* options, Bindings* bindings) {
  BindSampling(options, bindings);
  BindTracks(options, bindings);
  BindProposals(options, bindings);
  BindModel(options, bindings);
  BindFusionAndSchedule(options, bindings);
}

}  // namespace oslam
