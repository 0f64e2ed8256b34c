#include "apps/bindings.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "core/error.h"
#include "core/text.h"

namespace oslam {

std::string ParseInteger(const std::string& text, long min, long max, long* value) {
  char* end = nullptr;
  errno = 0;
  const long number = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size())
    return ": '" + text + "' is not an integer";
  if (errno == ERANGE || number < min || number > max) return ": '" + text + "' is out of range";
  *value = number;
  return "";
}

std::string ParseNumber(const std::string& text, bool infinity_allowed, double* value) {
  if (infinity_allowed && text == "inf") {
    *value = std::numeric_limits<double>::infinity();
    return "";
  }
  char* end = nullptr;
  const double number = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(number))
    return ": '" + text +
           (infinity_allowed ? "' is not a number or inf" : "' is not a finite number");
  *value = number;
  return "";
}

Binding::Binding(std::string flag, std::string value_name, std::string help, Getter get, Setter set)
    : flag_(std::move(flag)),
      value_name_(std::move(value_name)),
      help_(std::move(help)),
      get_(std::move(get)),
      set_(std::move(set)) {
  default_text_ = get_();
}

Binding& Binding::Key(std::string key, std::string help) {
  key_ = std::move(key);
  config_help_ = std::move(help);
  return *this;
}

Binding& Binding::ShowDefault(std::string text) {
  default_text_ = std::move(text);
  return *this;
}

Binding& Binding::Check(std::function<bool()> valid, std::string problem) {
  checks_.emplace_back(std::move(valid), " " + problem);
  return *this;
}

Binding& Binding::Quoted() {
  quoted_ = true;
  return *this;
}

std::string Binding::Set(const std::string& text) const {
  const std::string problem = set_(text);
  if (!problem.empty()) return problem;
  for (const auto& [valid, message] : checks_)
    if (!valid()) return message;
  return "";
}

Binding& Bindings::Push(Binding binding) {
  entries_.push_back(std::move(binding));
  return entries_.back();
}

Binding& Bindings::Add(int* field, const std::string& flag, const std::string& value_name,
                       const std::string& help) {
  return Push(Binding(
      flag, value_name, help, [field] { return std::to_string(*field); },
      [field](const std::string& text) {
        long value = 0;
        const std::string problem = ParseInteger(text, std::numeric_limits<int>::min(),
                                                 std::numeric_limits<int>::max(), &value);
        if (problem.empty()) *field = static_cast<int>(value);
        return problem;
      }));
}

Binding& Bindings::Add(long* field, const std::string& flag, const std::string& value_name,
                       const std::string& help) {
  return Push(Binding(
      flag, value_name, help, [field] { return std::to_string(*field); },
      [field](const std::string& text) {
        return ParseInteger(text, std::numeric_limits<long>::min(),
                            std::numeric_limits<long>::max(), field);
      }));
}

Binding& Bindings::Add(unsigned long* field, const std::string& flag, const std::string& value_name,
                       const std::string& help) {
  return Push(Binding(
      flag, value_name, help, [field] { return std::to_string(*field); },
      [field](const std::string& text) {
        long value = 0;
        std::string problem = ParseInteger(text, std::numeric_limits<long>::min(),
                                           std::numeric_limits<long>::max(), &value);
        if (problem.empty() && value < 0) problem = " must be >= 0";
        if (problem.empty()) *field = static_cast<unsigned long>(value);
        return problem;
      }));
}

Binding& Bindings::Add(double* field, const std::string& flag, const std::string& value_name,
                       const std::string& help) {
  return Push(Binding(
      flag, value_name, help, [field] { return Number(*field); },
      [field](const std::string& text) { return ParseNumber(text, false, field); }));
}

Binding& Bindings::AddNumberOrInfinity(double* field, const std::string& flag,
                                       const std::string& value_name, const std::string& help) {
  return Push(Binding(
      flag, value_name, help, [field] { return Number(*field); },
      [field](const std::string& text) { return ParseNumber(text, true, field); }));
}

Binding& Bindings::Add(std::string* field, const std::string& flag, const std::string& value_name,
                       const std::string& help) {
  return Push(Binding(
                  flag, value_name, help, [field] { return *field; },
                  [field](const std::string& text) {
                    *field = text;
                    return std::string();
                  }))
      .Quoted();
}

Binding& Bindings::AddCustom(const std::string& flag, const std::string& value_name,
                             const std::string& help, Binding::Getter get, Binding::Setter set) {
  return Push(Binding(flag, value_name, help, std::move(get), std::move(set)));
}

// A flag whose configuration value is the field (1 = true), or its inverse.
Binding& Bindings::PushFlag(bool* field, bool inverse, const std::string& flag,
                            const std::string& help) {
  Binding& binding = Push(Binding(
      flag, "", help, [field, inverse] { return std::string(*field != inverse ? "1" : "0"); },
      [field, inverse](const std::string& text) -> std::string {
        if (text != "0" && text != "1") return " must be 0 or 1, not '" + text + "'";
        *field = (text == "1") != inverse;
        return "";
      }));
  binding.is_flag_ = true;
  binding.default_text_.clear();  // a flag's default is its absence
  return binding;
}

Binding& Bindings::AddFlag(bool* field, const std::string& flag, const std::string& help) {
  return PushFlag(field, false, flag, help);
}

Binding& Bindings::AddNegatedFlag(bool* field, const std::string& flag, const std::string& help) {
  Binding& binding = PushFlag(field, false, flag, help);
  binding.negated_ = true;
  return binding;
}

Binding& Bindings::AddInvertedFlag(bool* field, const std::string& flag, const std::string& help) {
  return PushFlag(field, true, flag, help);
}

const Binding* Bindings::FindKey(const std::string& key) const {
  for (const Binding& binding : entries_)
    if (!binding.key().empty() && binding.key() == key) return &binding;
  return nullptr;
}

const Binding* Bindings::FindFlag(const std::string& flag) const {
  for (const Binding& binding : entries_)
    if (!binding.flag().empty() && binding.flag() == flag) return &binding;
  return nullptr;
}

void Bindings::Declare(Arguments* arguments) const {
  for (const Binding& binding : entries_) {
    if (binding.flag().empty()) continue;
    if (binding.is_flag())
      arguments->AddFlag(binding.flag(), binding.help());
    else
      arguments->AddOption(binding.flag(), "", binding.value_name(), binding.help(),
                           binding.default_text());
  }
}

void Bindings::Apply(const Arguments& arguments) const {
  for (const Binding& binding : entries_) {
    if (binding.flag().empty() || !arguments.Has(binding.flag())) continue;
    const std::string text =
        binding.is_flag() ? (binding.negated_ ? "0" : "1") : arguments.Get(binding.flag());
    const std::string problem = binding.Set(text);
    if (!problem.empty()) throw UsageError("--" + binding.flag() + problem);
  }
}

}  // namespace oslam
