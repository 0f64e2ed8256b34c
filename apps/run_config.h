// The one configuration of `oslam run`: every stage's parameters with their
// documented defaults, read from YAML (unknown keys are errors) and
// overridden on the command line with --set section.key=value. Each key maps
// onto an option of the stage's own command, so `oslam run` and the single
// commands cannot drift apart.
#pragma once

#include <string>
#include <vector>

namespace oslam {

struct ConfigEntry {
  std::string section;   // detect | slam | export | eval
  std::string key;       // name in the YAML file
  std::string value;     // as text; "" = not set (the option is not passed)
  std::string option;    // the stage command's option, e.g. "--min-area"
  bool is_flag = false;  // value 0/1; passed as a bare flag when 1
  std::string help;      // with unit and the spec reference
};

class RunConfig {
 public:
  RunConfig();  // the documented defaults

  // Throws oslam::Error naming the file and key for unknown sections/keys
  // and malformed values.
  void LoadYaml(const std::string& path);
  // "section.key=value"; throws UsageError.
  void Override(const std::string& assignment);

  const std::string& Get(const std::string& section, const std::string& key) const;
  // The stage command's options for `section` (values and set flags).
  std::vector<std::string> OptionsFor(const std::string& section) const;
  // The configuration as YAML with comments.
  std::string ToYaml() const;

 private:
  ConfigEntry* Find(const std::string& section, const std::string& key);
  std::vector<ConfigEntry> entries_;
};

}  // namespace oslam
