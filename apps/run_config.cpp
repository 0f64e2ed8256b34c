#include "apps/run_config.h"

#include <sstream>

#include "core/error.h"
#include "core/yaml.h"

namespace oslam {

RunConfig::RunConfig() {
  entries_ = {
      {"detect", "min_area_px", "40", "--min-area", false, "smallest colour blob kept, pixels"},
      {"detect", "opening_radius_px", "1", "--opening", false, "morphological opening, 0 = off"},
      {"detect", "sift_templates", "", "--sift-templates", false,
       "templates.yaml for SIFT verification; empty = colour only"},
      {"detect", "skip_bad_frames", "0", "--skip-bad-frames", true,
       "1: warn about unreadable frames and go on instead of stopping"},
      {"slam", "method", "oslam", "", false, "oslam (MCMC over association and classes) or nn (baseline)"},
      {"slam", "seed", "1", "--seed", false, "seed of every random choice of the sampler"},
      {"slam", "samples", "667", "--samples", false, "MC3 iterations incl. burn-in (spec §9.8, §13 #21)"},
      {"slam", "burn_in", "70", "--burn-in", false, "iterations discarded (spec §9.8)"},
      {"slam", "hill_climb", "100", "--hill-climb", false, "hill-climbing steps (spec §9.7)"},
      {"slam", "chains", "3", "--chains", false, "MC3 chains, 1 = Metropolis-Hastings (spec §9.4)"},
      {"slam", "delta_t", "3.33", "--delta-t", false, "temperature step between chains (spec §9.4)"},
      {"slam", "min_track_length", "3", "--min-track-length", false,
       "drop tracks with fewer detections (spec §6.3, §9.7)"},
      {"slam", "proposal_iterations", "1", "--proposal-iterations", false,
       "solver iterations per proposed state (spec §9.6)"},
      {"slam", "mismatch_penalty", "3", "--mismatch-penalty", false,
       "class-mismatch factor in the merge proposal (spec §13 #15)"},
      {"slam", "location_std_xy_m", "10", "--location-std-xy", false,
       "class location prior std in x and y, m (spec §13 #7)"},
      {"slam", "location_std_z_m", "2", "--location-std-z", false, "class location prior std in z, m"},
      {"export", "min_existence", "0.1", "--min-existence", false,
       "leave out objects with a lower existence probability"},
      {"export", "overlays", "1", "--overlays", true, "1: draw the map on every frame"},
      {"export", "overlay_frames", "", "--frames", false, "only these frames, e.g. 0,10,20-30"},
      {"export", "figure_size_px", "800", "--figure-size", false, "width and height of the figures"},
      {"eval", "threshold", "0.5", "--threshold", false,
       "objects at or below this existence probability are not in the map"},
      {"eval", "gate_m", "0.5", "--gate", false, "largest base-point distance of a match, m"},
  };
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
        std::ostringstream text;
        text << static_cast<double>(value);
        entry->value = text.str();
      } else {
        file.Fail(section + "." + key, "must be a number or a string");
      }
      if (entry->is_flag && entry->value != "0" && entry->value != "1")
        file.Fail(section + "." + key, "must be 0 or 1");
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
  entry->value = assignment.substr(equals + 1);
  if (entry->is_flag && entry->value != "0" && entry->value != "1")
    throw UsageError("--set " + assignment.substr(0, equals) + " must be 0 or 1");
}

std::vector<std::string> RunConfig::OptionsFor(const std::string& section) const {
  std::vector<std::string> options;
  for (const ConfigEntry& e : entries_) {
    if (e.section != section || e.option.empty() || e.value.empty()) continue;
    if (e.is_flag) {
      if (e.value == "1") options.push_back(e.option);
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
    const bool numeric = !e.value.empty() && e.value.find_first_not_of("0123456789.-+e") == std::string::npos;
    out << "  " << e.key << ": " << (numeric ? e.value : "\"" + e.value + "\"") << "  # " << e.help
        << "\n";
  }
  return out.str();
}

}  // namespace oslam
