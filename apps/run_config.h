// The one configuration of `oslam run`: the options of every stage
// (RunPipelineOptions) read from YAML (unknown keys are errors) and
// overridden on the command line with --set section.key=value. The sections
// detect, slam, export and eval are the binding tables of the stages'
// single commands (apps/stage_bindings.h), so `oslam run` and the single
// commands cannot drift apart, and every default is the options struct's.
#pragma once

#include <string>
#include <vector>

#include "apps/bindings.h"
#include "pipeline/run_pipeline.h"

namespace oslam {

class RunConfig {
 public:
  RunConfig();  // RunPipelineOptions' defaults
  // The bindings point into this object's options.
  RunConfig(const RunConfig&) = delete;
  RunConfig& operator=(const RunConfig&) = delete;

  // Throws oslam::Error naming the file and key for unknown sections/keys
  // and malformed or out-of-range values.
  void LoadYaml(const std::string& path);
  // "section.key=value"; throws UsageError.
  void Override(const std::string& assignment);
  // Values that are each well-formed but not valid together (e.g. burn-in
  // beyond the samples): one line; oslam::Error naming the file when every
  // value came from the loaded file, UsageError otherwise. Call before
  // running anything.
  void Check() const;

  const RunPipelineOptions& options() const { return options_; }
  // The sections in the order of the YAML file.
  std::vector<const Bindings*> sections() const;
  // The binding of "section.key"; nullptr when there is none.
  const Binding* Find(const std::string& section, const std::string& key) const;
  // The configuration as YAML with comments.
  std::string ToYaml() const;

 private:
  RunPipelineOptions options_;
  Bindings detect_{"detect"}, slam_{"slam"}, export_{"export"}, eval_{"eval"}, frames_{"frames"};
  std::string file_;         // the YAML file loaded, if any
  bool overridden_ = false;  // a --set was applied
};

}  // namespace oslam
