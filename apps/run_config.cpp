#include "apps/run_config.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "apps/stage_bindings.h"
#include "core/error.h"
#include "core/text.h"
#include "core/yaml.h"

namespace oslam {
namespace {

bool IsNumber(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size() && std::isfinite(value);
}

std::vector<std::string> Keys(const Bindings& section) {
  std::vector<std::string> keys;
  for (const Binding& binding : section.entries())
    if (!binding.key().empty()) keys.push_back(binding.key());
  return keys;
}

}  // namespace

RunConfig::RunConfig() {
  BindDetectOptions(&options_.detect, &detect_);
  BindSlamOptions(&options_.slam, &slam_);
  BindExportOptions(&options_.export_, &export_);
  BindEvalOptions(&options_.eval, &eval_);
  BindFrameOptions(&options_.frames, &frames_);
}

std::vector<const Bindings*> RunConfig::sections() const {
  return {&frames_, &detect_, &slam_, &export_, &eval_};
}

const Binding* RunConfig::Find(const std::string& section, const std::string& key) const {
  for (const Bindings* bindings : sections())
    if (bindings->section() == section) return bindings->FindKey(key);
  return nullptr;
}

void RunConfig::LoadYaml(const std::string& path) {
  YamlFile file(path);
  file_ = path;
  std::vector<std::string> names;
  for (const Bindings* section : sections()) names.push_back(section->section());
  file.RequireOnlyKeys(file.root(), "", names);
  for (const Bindings* section : sections()) {
    const std::string& name = section->section();
    const cv::FileNode node = file.root()[name];
    if (node.empty() || node.isNone()) continue;
    if (!node.isMap()) file.Fail(name, "must be a mapping of key: value");
    file.RequireOnlyKeys(node, name + ".", Keys(*section));
    for (const std::string& key : Keys(*section)) {
      const cv::FileNode value = node[key];
      if (value.empty() || value.isNone()) continue;
      std::string text;
      if (value.isString()) {
        text = static_cast<std::string>(value);
      } else if (value.isInt()) {
        text = std::to_string(static_cast<int>(value));
      } else if (value.isReal()) {
        text = Number(static_cast<double>(value));
      } else {
        file.Fail(name + "." + key, "must be a number or a string");
      }
      const std::string problem = section->FindKey(key)->Set(text);
      if (!problem.empty()) throw Error::InFile(path, name + "." + key + problem);
    }
  }
}

void RunConfig::Override(const std::string& assignment) {
  const size_t dot = assignment.find('.'), equals = assignment.find('=');
  if (dot == std::string::npos || equals == std::string::npos || dot > equals)
    throw UsageError("--set expects section.key=value, got '" + assignment + "'");
  const std::string name = assignment.substr(0, equals);
  const Binding* binding = Find(name.substr(0, dot), name.substr(dot + 1));
  if (!binding)
    throw UsageError("--set: unknown key '" + name + "' (see 'oslam config --print-defaults')");
  const std::string problem = binding->Set(assignment.substr(equals + 1));
  if (!problem.empty()) throw UsageError("--set " + name + problem);
  overridden_ = true;
}

void RunConfig::Check() const {
  std::string why;
  if (options_.Validate(&why)) return;
  if (!file_.empty() && !overridden_) throw Error::InFile(file_, "configuration: " + why);
  throw UsageError("configuration: " + why);
}

std::string RunConfig::ToYaml() const {
  std::ostringstream out;
  out << "# oslam run configuration (oslam config --print-defaults). Units: SI.\n";
  for (const Bindings* section : sections()) {
    out << section->section() << ":\n";
    for (const Binding& binding : section->entries()) {
      if (binding.key().empty()) continue;
      const std::string value = binding.Value();
      const bool bare = !binding.quoted() && IsNumber(value);
      out << "  " << binding.key() << ": " << (bare ? value : "\"" + value + "\"") << "  # "
          << binding.config_help() << "\n";
    }
  }
  return out.str();
}

}  // namespace oslam
