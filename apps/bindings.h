// Parameters bound to the fields of options structs. Each binding names the
// command-line flag, the `oslam run` configuration key (the key within the
// table's section), the help texts and a pointer to the field it sets. The
// default shown in --help and `oslam config --print-defaults` is the field's
// value when the binding is made: bound to a default-constructed struct, it
// is the struct's default, so every parameter has its default in one place.
//
// The pointers are to one struct instance: a table must not outlive it.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "apps/arguments.h"

namespace oslam {

// The parsers of the bindings: "" when `text` is well-formed (and in
// range), else the rest of a message after the parameter's name.
std::string ParseInteger(const std::string& text, long min, long max, long* value);
std::string ParseNumber(const std::string& text, bool infinity_allowed, double* value);

class Binding {
 public:
  // Reads the field as text, and sets it from text. `set` returns "" or the
  // rest of a message that follows the parameter's name: ": 'x' is not an
  // integer" (malformed) or " must be >= 0" (out of range).
  using Getter = std::function<std::string()>;
  using Setter = std::function<std::string(const std::string&)>;

  Binding(std::string flag, std::string value_name, std::string help, Getter get, Setter set);

  // The configuration key in the table's section; `help` is the comment in
  // the YAML file ("" = the command line's help).
  Binding& Key(std::string key, std::string help = "");
  // A text shown as the default instead of the field's value
  // ("RUN_DIR/detections.csv"); "" shows none.
  Binding& ShowDefault(std::string text);
  // The value must pass `valid` (read from the bound field after it is set),
  // else the message is the name followed by " " + problem.
  Binding& Check(std::function<bool()> valid, std::string problem);
  // Written in quotes in the YAML file whatever it holds (texts, lists).
  Binding& Quoted();

  const std::string& flag() const { return flag_; }  // "" = not on the command line
  const std::string& key() const { return key_; }    // "" = not in the configuration
  const std::string& value_name() const { return value_name_; }
  const std::string& help() const { return help_; }
  const std::string& config_help() const { return config_help_.empty() ? help_ : config_help_; }
  const std::string& default_text() const { return default_text_; }
  bool is_flag() const { return is_flag_; }
  bool quoted() const { return quoted_; }

  std::string Value() const { return get_(); }
  // "" when set, else the rest of the message after the name (see Setter).
  std::string Set(const std::string& text) const;

 private:
  friend class Bindings;
  std::string flag_, value_name_, help_, key_, config_help_, default_text_;
  bool is_flag_ = false;
  bool negated_ = false;  // the flag sets the field to false (--no-...)
  bool quoted_ = false;
  Getter get_;
  Setter set_;
  std::vector<std::pair<std::function<bool()>, std::string>> checks_;
};

// The bindings of one command or one configuration section, in the order of
// --help and of the YAML file.
class Bindings {
 public:
  explicit Bindings(std::string section = "") : section_(std::move(section)) {}
  Bindings(const Bindings&) = delete;
  Bindings& operator=(const Bindings&) = delete;

  Binding& Add(int* field, const std::string& flag, const std::string& value_name,
               const std::string& help);
  Binding& Add(long* field, const std::string& flag, const std::string& value_name,
               const std::string& help);
  Binding& Add(unsigned long* field, const std::string& flag, const std::string& value_name,
               const std::string& help);
  // A finite number.
  Binding& Add(double* field, const std::string& flag, const std::string& value_name,
               const std::string& help);
  Binding& Add(std::string* field, const std::string& flag, const std::string& value_name,
               const std::string& help);
  // A finite number or "inf" (limits and penalties that may be off).
  Binding& AddNumberOrInfinity(double* field, const std::string& flag,
                               const std::string& value_name, const std::string& help);
  // --flag sets the field to true; in the configuration 0 or 1.
  Binding& AddFlag(bool* field, const std::string& flag, const std::string& help);
  // --flag (e.g. --no-grid) sets the field to false; in the configuration
  // the field itself, 0 or 1 (floor_grid: 1).
  Binding& AddNegatedFlag(bool* field, const std::string& flag, const std::string& help);
  // --flag sets the field to false, and so does 1 in the configuration
  // (keep_look_alikes: 1 = separate_look_alikes false).
  Binding& AddInvertedFlag(bool* field, const std::string& flag, const std::string& help);
  // One of named values.
  template <typename T>
  Binding& AddChoice(T* field, std::vector<std::pair<std::string, T>> choices,
                     const std::string& flag, const std::string& value_name,
                     const std::string& help);
  Binding& AddCustom(const std::string& flag, const std::string& value_name,
                     const std::string& help, Binding::Getter get, Binding::Setter set);

  const std::string& section() const { return section_; }
  const std::vector<Binding>& entries() const { return entries_; }
  // The binding of a configuration key or a flag; nullptr when there is none.
  const Binding* FindKey(const std::string& key) const;
  const Binding* FindFlag(const std::string& flag) const;

  // Declares every binding with a flag as an option of `arguments`.
  void Declare(Arguments* arguments) const;
  // Sets the fields of the options given on the command line; throws
  // UsageError "--flag: ..." for a malformed or out-of-range value.
  void Apply(const Arguments& arguments) const;

 private:
  Binding& Push(Binding binding);
  Binding& PushFlag(bool* field, bool inverse, const std::string& flag, const std::string& help);

  std::string section_;
  std::vector<Binding> entries_;
};

template <typename T>
Binding& Bindings::AddChoice(T* field, std::vector<std::pair<std::string, T>> choices,
                             const std::string& flag, const std::string& value_name,
                             const std::string& help) {
  auto get = [field, choices] {
    for (const auto& [name, value] : choices)
      if (*field == value) return name;
    return std::string();
  };
  auto set = [field, choices](const std::string& text) -> std::string {
    std::string names;
    for (size_t i = 0; i < choices.size(); ++i) {
      if (choices[i].first == text) {
        *field = choices[i].second;
        return "";
      }
      names += (i == 0                    ? ""
                : i + 1 == choices.size() ? " or "
                                          : ", ") +
               ("'" + choices[i].first + "'");
    }
    return " must be " + names + ", not '" + text + "'";
  };
  return AddCustom(flag, value_name, help, get, set).Quoted();
}

}  // namespace oslam
