// The one configuration of `oslam run`: every stage's parameters with their
// documented defaults, read from YAML (unknown keys are errors) and
// overridden on the command line with --set section.key=value. Each key maps
// onto an option of the stage's own command, so `oslam run` and the single
// commands cannot drift apart; the slam section's defaults are those the
// `oslam slam` options declare (from the mapping code's option structs).
#pragma once

#include <string>
#include <vector>

namespace oslam {

struct ConfigEntry {
  enum class Kind { kInteger, kNumber, kNumberOrInf, kFlag, kText, kTriple };
  std::string section;  // detect | slam | export | eval
  std::string key;      // name in the YAML file
  std::string value;    // as text; "" = not set (the option is not passed)
  std::string option;   // the stage command's option, e.g. "--min-area"
  Kind kind = Kind::kText;
  std::string help;      // with unit and the spec reference
  bool negated = false;  // a flag whose option is passed when the value is 0 ("--no-...")
};

class RunConfig {
 public:
  RunConfig();  // the documented defaults

  // Throws oslam::Error naming the file and key for unknown sections/keys
  // and malformed values.
  void LoadYaml(const std::string& path);
  // "section.key=value"; throws UsageError.
  void Override(const std::string& assignment);
  // Values that are each well-formed but not valid together or out of range
  // (e.g. burn-in beyond the samples, a negative noise): one line naming the
  // key; oslam::Error naming the file when every value came from the loaded
  // file, UsageError otherwise. Call before running anything.
  void Check() const;

  const std::string& Get(const std::string& section, const std::string& key) const;
  const std::vector<ConfigEntry>& entries() const { return entries_; }
  // The stage command's options for `section` (values and set flags).
  std::vector<std::string> OptionsFor(const std::string& section) const;
  // The configuration as YAML with comments.
  std::string ToYaml() const;

 private:
  ConfigEntry* Find(const std::string& section, const std::string& key);
  [[noreturn]] void Fail(const std::string& message) const;
  std::vector<ConfigEntry> entries_;
  std::string file_;         // the YAML file loaded, if any
  bool overridden_ = false;  // a --set was applied
};

// "" when `value` is well-formed for `kind`, otherwise what is wrong with it.
std::string ConfigValueProblem(ConfigEntry::Kind kind, const std::string& value);

}  // namespace oslam
