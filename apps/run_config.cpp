#include "apps/run_config.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "apps/arguments.h"
#include "apps/slam_options.h"
#include "core/error.h"
#include "core/yaml.h"
#include "detect/blob_detector.h"
#include "export/export_scene.h"
#include "export/figures.h"

namespace oslam {

namespace {

using Kind = ConfigEntry::Kind;

// Shortest text that reads back as the same double.
std::string Number(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

bool IsNumber(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size() && std::isfinite(value);
}

}  // namespace

std::string ConfigValueProblem(ConfigEntry::Kind kind, const std::string& value) {
  switch (kind) {
    case Kind::kInteger: {
      char* end = nullptr;
      const long number = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || end != value.c_str() + value.size())
        return "'" + value + "' is not an integer";
      if (number < std::numeric_limits<int>::min() || number > std::numeric_limits<int>::max())
        return "'" + value + "' is out of range";
      return "";
    }
    case Kind::kNumber:
      return IsNumber(value) ? "" : "'" + value + "' is not a finite number";
    case Kind::kNumberOrInf:
      return IsNumber(value) || value == "inf" ? "" : "'" + value + "' is not a number or inf";
    case Kind::kFlag:
      return value == "0" || value == "1" ? "" : "must be 0 or 1, not '" + value + "'";
    case Kind::kTriple: {
      std::stringstream items(value);
      std::string item;
      int count = 0;
      bool numbers = true;
      while (std::getline(items, item, ',')) {
        ++count;
        numbers &= IsNumber(item);
      }
      if (count != 3 || !numbers)
        return "'" + value + "' is not three probabilities merge,split,switch like 0.4,0.4,0.2";
      return "";
    }
    case Kind::kText:
      return "";
  }
  return "";
}

RunConfig::RunConfig() {
  entries_ = {
      {"detect", "min_area_px", "40", "--min-area", Kind::kInteger,
       "smallest colour blob kept, pixels"},
      {"detect", "opening_radius_px", "1", "--opening", Kind::kInteger,
       "morphological opening, 0 = off"},
      {"detect", "colour_box", "scaled", "--colour-box", Kind::kText,
       "yuv = the thesis' mean +- k sigma YUV box; scaled = chroma scaled with brightness"},
      {"detect", "brightness_range", "2.5", "--brightness-range", Kind::kNumber,
       "colour_box scaled: accept brightness from 1/R to R times the examples' range"},
      {"detect", "keep_look_alikes", "0", "--keep-look-alikes", Kind::kFlag,
       "1: keep every class a blob's colour matches (thesis); 0: of look-alike classes on the "
       "same pixels keep the one whose colour and image shape fit better"},
      {"detect", "max_shape_distance", "inf", "--max-shape-distance", Kind::kNumberOrInf,
       "drop detections whose slice elongation is further than this many sigmas from their "
       "class's image shape; inf = off"},
      {"detect", "sift_templates", "", "--sift-templates", Kind::kText,
       "templates.yaml for SIFT verification; empty = colour only"},
      {"detect", "threads", "2", "--threads", Kind::kInteger,
       "frames decoded and searched at once, 0 = one per core (same output)"},
      {"detect", "skip_bad_frames", "0", "--skip-bad-frames", Kind::kFlag,
       "1: warn about unreadable frames and go on instead of stopping"},
      {"slam", "method", "oslam", "", Kind::kText,
       "oslam (MCMC over association and classes) or nn (baseline)"},
      {"slam", "seed", "", "--seed", Kind::kInteger, "seed of every random choice of the sampler"},
      {"slam", "samples", "", "--samples", Kind::kInteger,
       "MC3 iterations incl. burn-in (spec §9.8, §13 #21)"},
      {"slam", "burn_in", "", "--burn-in", Kind::kInteger, "iterations discarded (spec §9.8)"},
      {"slam", "hill_climb", "", "--hill-climb", Kind::kInteger,
       "hill-climbing steps, the minimum (spec §9.7)"},
      {"slam", "hill_climb_patience", "", "--hill-climb-patience", Kind::kInteger,
       "then climb on while a move was accepted in the last N steps (0 = fixed count)"},
      {"slam", "hill_climb_max", "", "--hill-climb-max", Kind::kInteger,
       "at most this many hill-climbing steps"},
      {"slam", "refine_every", "", "--refine-every", Kind::kInteger,
       "K_NL: full re-optimisation every N hill-climbing steps (spec §9.7)"},
      {"slam", "hill_climb_moves", "", "--hill-climb-moves", Kind::kTriple,
       "merge,split,switch probabilities in hill climbing (spec §9.8)"},
      {"slam", "sampling_moves", "", "--sampling-moves", Kind::kTriple,
       "merge,split,switch probabilities in MC3; known_classes: switch 0, rest rescaled"},
      {"slam", "chains", "", "--chains", Kind::kInteger,
       "MC3 chains, 1 = Metropolis-Hastings (spec §9.4)"},
      {"slam", "delta_t", "", "--delta-t", Kind::kNumber,
       "temperature step between chains (spec §9.4)"},
      {"slam", "known_classes", "0", "--known-classes", Kind::kFlag,
       "1: detected classes are right (no switch moves, no merges across classes; Sec. 6.2)"},
      {"slam", "min_track_length", "", "--min-track-length", Kind::kInteger,
       "drop tracks with fewer detections (spec §6.3, §9.8)"},
      {"slam", "track_gate_radius_px", "", "--gate-radius", Kind::kNumber,
       "track pre-association: largest |du_r|, px (eq. 6.1)"},
      {"slam", "track_gate_angle_rad", "", "--gate-angle", Kind::kNumber,
       "track pre-association: largest |du_phi|, rad (eq. 6.1: 20 deg, §13 #20)"},
      {"slam", "track_gate_size_change", "", "--gate-size-change", Kind::kNumber,
       "track pre-association: largest |ds_r|, |ds_phi| as a fraction of the smaller (eq. 6.1)"},
      {"slam", "track_link_rule", "", "--link-rule", Kind::kText,
       "nearest (one-to-one, closest first) or refuse-ambiguous (spec §13 #20)"},
      {"slam", "track_max_gap_frames", "", "--max-gap", Kind::kInteger,
       "join tracks across up to N missed frames (occlusions; 0 = thesis)"},
      {"slam", "proposal_iterations", "", "--proposal-iterations", Kind::kInteger,
       "solver iterations per proposed state (spec §9.6, §13 #46)"},
      {"slam", "class_prior_per_object", "0", "--class-prior-per-object", Kind::kFlag,
       "1: P(C, J) = prod_j 1/|classes|; 0: uniform joint (spec §13 #13/#37)"},
      {"slam", "mismatch_penalty", "", "--mismatch-penalty", Kind::kNumberOrInf,
       "class-mismatch factor in the merge proposal, inf = never (spec §13 #15)"},
      {"slam", "merge_distance_m", "", "--merge-distance", Kind::kNumber,
       "merge proposal distance threshold d_thr, m (spec §9.8)"},
      {"slam", "merge_sigma_m", "", "--merge-sigma", Kind::kNumber,
       "merge proposal sigma_E, m (spec §13 #14)"},
      {"slam", "class_proposal_uniform", "", "--class-proposal-uniform", Kind::kNumber,
       "uniform share of the class drawn by merge/split/switch (0 = thesis)"},
      {"slam", "merge_count_smoothing", "", "--merge-count-smoothing", Kind::kNumber,
       "epsilon_d added to every d_j (spec §13 #16)"},
      {"slam", "merge_count_includes_self", "0", "--merge-count-includes-self", Kind::kFlag,
       "1: d_j counts o_j itself (spec §13 #41)"},
      {"slam", "split_sampler", "", "--split-sampler", Kind::kText,
       "uniform (non-empty subset) or thesis (Algorithm 6) (spec §13 #18/#43)"},
      {"slam", "confusion_floor", "", "--confusion-floor", Kind::kNumber,
       "smallest class confusion probability P(a | c); rows renormalised (spec §13 #12)"},
      {"slam", "location_std_xy_m", "", "--location-std-xy", Kind::kNumber,
       "class location prior std in x and y, m (spec §13 #7)"},
      {"slam", "location_std_z_m", "", "--location-std-z", Kind::kNumber,
       "class location prior std in z, m (spec §13 #7)"},
      {"slam", "pixel_noise_px", "", "--pixel-noise", Kind::kNumber,
       "detection noise E, px: R = diag(E^2, (E/u_r)^2) (spec §4.2, §13 #5)"},
      {"slam", "motion_add_fwd_m", "", "--motion-add-fwd", Kind::kNumber,
       "odometry noise Q_add, forward std, m (spec §4.1, §13 #1)"},
      {"slam", "motion_add_lat_m", "", "--motion-add-lat", Kind::kNumber,
       "odometry noise Q_add, lateral std, m"},
      {"slam", "motion_add_heading_rad", "", "--motion-add-heading", Kind::kNumber,
       "odometry noise Q_add, heading std, rad (1 deg)"},
      {"slam", "motion_mult_fwd", "", "--motion-mult-fwd", Kind::kNumber,
       "odometry noise Q_mult, forward, times |v_r|"},
      {"slam", "motion_mult_lat", "", "--motion-mult-lat", Kind::kNumber,
       "odometry noise Q_mult, lateral, times |v_r|"},
      {"slam", "motion_mult_heading", "", "--motion-mult-heading", Kind::kNumber,
       "odometry noise Q_mult, heading, times |v_phi|"},
      {"slam", "motion_noise_is_variance", "0", "--motion-variances", Kind::kFlag,
       "1: read Q_add and Q_mult as variances instead of std devs (spec §13 #2)"},
      {"slam", "motion_heading_by_distance", "0", "--motion-heading-by-distance", Kind::kFlag,
       "1: the heading row of Q_mult scales with |v_r| instead of |v_phi| (spec §13 #2)"},
      {"slam", "motion_world_frame", "0", "--motion-world-frame", Kind::kFlag,
       "1: Q_i in the world frame, not rotated from the robot frame (spec §13 #2)"},
      {"slam", "solver_iterations", "", "--solver-iterations", Kind::kInteger,
       "full optimisation: most Levenberg-Marquardt iterations (spec §5.4, §13 #8)"},
      {"slam", "solver_step_tolerance", "", "--solver-step-tolerance", Kind::kNumber,
       "full optimisation: converged when max |step| < this, m and rad (spec §5.4)"},
      {"slam", "spurious_model", "1", "--no-spurious-model", Kind::kFlag,
       "1: existence weighted by P(xi), the spurious-object sigmoid (spec §7.2)", true},
      {"slam", "spurious_t0_m2", "", "--spurious-t0", Kind::kNumber,
       "spurious sigmoid t0, m^2: (0.4 m)^2 (spec §7.2, §9.8)"},
      {"slam", "spurious_tau_m2", "", "--spurious-tau", Kind::kNumber,
       "spurious sigmoid tau, m^2: (0.2 m)^2 (spec §7.2, §9.8)"},
      {"slam", "class_likelihood_per_detection", "0", "--class-likelihood-per-detection",
       Kind::kFlag, "1: log P(a | c) once per detection (eq. 4.32), 0: once per track"},
      {"slam", "swap_every", "", "--swap-every", Kind::kInteger,
       "MC3: chains may swap after every this many iterations (1 = thesis)"},
      {"slam", "speculation_depth", "", "--speculation-depth", Kind::kInteger,
       "MC3 on threads: swap intervals a chain may run ahead (0 = lock-step; same result)"},
      {"slam", "hill_climb_screen_nats", "", "--hill-climb-screen", Kind::kNumberOrInf,
       "hill climbing: no solve when the approximate gain is below -this, inf = always solve"},
      {"slam", "delayed_acceptance", "1", "--no-delayed-acceptance", Kind::kFlag,
       "1: MC3 proposals screened before they are solved, same posterior (docs/oslam.md)", true},
      {"slam", "identity_merge", "1", "--no-identity-merge", Kind::kFlag,
       "1: combine sample identities of one object (beyond the thesis, docs/oslam.md 6a)", true},
      {"slam", "identity_distance_m", "", "--identity-distance", Kind::kNumber,
       "identity merging: largest distance of combined identities, m"},
      {"slam", "identity_mismatch_penalty", "", "--identity-mismatch-penalty", Kind::kNumberOrInf,
       "identity merging: squared-distance factor across classes, inf = never"},
      {"slam", "identity_max_cooccurrence", "", "--identity-max-cooccurrence", Kind::kNumber,
       "identity merging: largest fraction of the rarer identity's samples holding both"},
      {"slam", "nn_gate_m", "", "--nn-gate", Kind::kNumber,
       "method nn: nearest-neighbour association gate, m"},
      {"export", "min_existence", "0.1", "--min-existence", Kind::kNumber,
       "leave out objects with a lower existence probability"},
      {"export", "overlays", "1", "--overlays", Kind::kFlag, "1: draw the map on every frame"},
      {"export", "overlay_frames", "", "--frames", Kind::kText,
       "only these frames, e.g. 0,10,20-30"},
      {"export", "threads", "2", "--threads", Kind::kInteger,
       "overlays drawn and written at once, 0 = one per core (same output)"},
      {"export", "figure_size_px", "800", "--figure-size", Kind::kInteger,
       "width and height of the figures"},
      {"export", "floor_grid", "1", "--no-grid", Kind::kFlag, "1: a floor grid in the glTF", true},
      {"export", "ascii_ply", "0", "--ascii-ply", Kind::kFlag, "1: ASCII PLY instead of binary"},
      {"eval", "threshold", "0.5", "--threshold", Kind::kNumber,
       "objects at or below this existence probability are not in the map"},
      {"eval", "gate_m", "0.5", "--gate", Kind::kNumber,
       "largest base-point distance of a match, m"},
  };
  // The slam section's defaults are the `oslam slam` options' (one source).
  Arguments slam("", "");
  AddSlamOptions(&slam);
  for (ConfigEntry& e : entries_)
    if (e.section == "slam" && e.value.empty() && !e.option.empty())
      e.value = slam.Get(e.option.substr(2));
}

ConfigEntry* RunConfig::Find(const std::string& section, const std::string& key) {
  for (ConfigEntry& e : entries_)
    if (e.section == section && e.key == key) return &e;
  return nullptr;
}

const std::string& RunConfig::Get(const std::string& section, const std::string& key) const {
  for (const ConfigEntry& e : entries_)
    if (e.section == section && e.key == key) return e.value;
  throw Error("internal: no configuration key " + section + "." + key);
}

void RunConfig::LoadYaml(const std::string& path) {
  YamlFile file(path);
  file_ = path;
  std::vector<std::string> sections;
  for (const ConfigEntry& e : entries_)
    if (sections.empty() || sections.back() != e.section) sections.push_back(e.section);
  file.RequireOnlyKeys(file.root(), "", sections);
  for (const std::string& section : sections) {
    const cv::FileNode node = file.root()[section];
    if (node.empty() || node.isNone()) continue;
    if (!node.isMap()) file.Fail(section, "must be a mapping of key: value");
    std::vector<std::string> keys;
    for (const ConfigEntry& e : entries_)
      if (e.section == section) keys.push_back(e.key);
    file.RequireOnlyKeys(node, section + ".", keys);
    for (const std::string& key : keys) {
      const cv::FileNode value = node[key];
      if (value.empty() || value.isNone()) continue;
      ConfigEntry* entry = Find(section, key);
      if (value.isString()) {
        entry->value = static_cast<std::string>(value);
      } else if (value.isInt()) {
        entry->value = std::to_string(static_cast<int>(value));
      } else if (value.isReal()) {
        entry->value = Number(static_cast<double>(value));
      } else {
        file.Fail(section + "." + key, "must be a number or a string");
      }
      const std::string problem = ConfigValueProblem(entry->kind, entry->value);
      if (!problem.empty()) file.Fail(section + "." + key, problem);
    }
  }
}

void RunConfig::Override(const std::string& assignment) {
  const size_t dot = assignment.find('.'), equals = assignment.find('=');
  if (dot == std::string::npos || equals == std::string::npos || dot > equals)
    throw UsageError("--set expects section.key=value, got '" + assignment + "'");
  ConfigEntry* entry =
      Find(assignment.substr(0, dot), assignment.substr(dot + 1, equals - dot - 1));
  if (!entry)
    throw UsageError("--set: unknown key '" + assignment.substr(0, equals) +
                     "' (see 'oslam config --print-defaults')");
  const std::string value = assignment.substr(equals + 1);
  const std::string problem = ConfigValueProblem(entry->kind, value);
  if (!problem.empty()) throw UsageError("--set " + assignment.substr(0, equals) + ": " + problem);
  entry->value = value;
  overridden_ = true;
}

void RunConfig::Fail(const std::string& message) const {
  if (!file_.empty() && !overridden_) throw Error::InFile(file_, message);
  throw UsageError(message);
}

void RunConfig::Check() const {
  for (const ConfigEntry& e : entries_) {
    const std::string problem = ConfigValueProblem(e.kind, e.value);
    if (!problem.empty()) Fail(e.section + "." + e.key + ": " + problem);
  }
  const std::string method = Get("slam", "method");
  if (method != "oslam" && method != "nn")
    Fail("slam.method must be oslam or nn, not '" + method + "'");
  // The slam section through the very parser `oslam slam` uses, with its
  // option names turned back into configuration keys in the message.
  Arguments slam("", "");
  AddSlamOptions(&slam);
  try {
    slam.Parse(OptionsFor("slam"));
    SlamSettingsFrom(slam);
  } catch (const UsageError& e) {
    std::string message = e.what();
    for (const ConfigEntry& entry : entries_) {
      if (entry.section != "slam" || entry.option.empty()) continue;
      for (size_t at = message.find(entry.option); at != std::string::npos;
           at = message.find(entry.option, at + 1)) {
        const size_t end = at + entry.option.size();
        if (end < message.size() &&
            (std::isalnum(static_cast<unsigned char>(message[end])) || message[end] == '-'))
          continue;
        message.replace(at, entry.option.size(), "slam." + entry.key);
      }
    }
    Fail("configuration: " + message);
  }
  BlobDetectorOptions detect;
  detect.min_area_px = std::stoi(Get("detect", "min_area_px"));
  detect.opening_radius_px = std::stoi(Get("detect", "opening_radius_px"));
  if (!ParseColourBoxShape(Get("detect", "colour_box"), &detect.colour.shape))
    Fail("configuration: detect.colour_box must be 'yuv' or 'scaled'");
  detect.colour.brightness_range = std::stod(Get("detect", "brightness_range"));
  detect.separate_look_alikes = Get("detect", "keep_look_alikes") == "0";
  detect.max_shape_distance = Get("detect", "max_shape_distance") == "inf"
                                  ? std::numeric_limits<double>::infinity()
                                  : std::stod(Get("detect", "max_shape_distance"));
  ExportOptions models;
  models.min_existence = std::stod(Get("export", "min_existence"));
  FigureOptions figures;
  figures.min_existence = models.min_existence;
  figures.width_px = figures.height_px = std::stoi(Get("export", "figure_size_px"));
  std::string why;
  if (!detect.Validate(&why) || !models.Validate(&why) || !figures.Validate(&why))
    Fail("configuration: " + why);
}

std::vector<std::string> RunConfig::OptionsFor(const std::string& section) const {
  std::vector<std::string> options;
  for (const ConfigEntry& e : entries_) {
    if (e.section != section || e.option.empty() || e.value.empty()) continue;
    if (e.kind == Kind::kFlag) {
      if (e.value == (e.negated ? "0" : "1")) options.push_back(e.option);
    } else {
      options.push_back(e.option);
      options.push_back(e.value);
    }
  }
  return options;
}

std::string RunConfig::ToYaml() const {
  std::ostringstream out;
  out << "# oslam run configuration (oslam config --print-defaults). Units: SI.\n";
  std::string section;
  for (const ConfigEntry& e : entries_) {
    if (e.section != section) {
      section = e.section;
      out << section << ":\n";
    }
    const bool numeric = e.kind != Kind::kText && e.kind != Kind::kTriple && IsNumber(e.value);
    out << "  " << e.key << ": " << (numeric ? e.value : "\"" + e.value + "\"") << "  # " << e.help
        << "\n";
  }
  return out.str();
}

}  // namespace oslam
