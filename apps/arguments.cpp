#include "apps/arguments.h"

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <sstream>

#include "core/error.h"

namespace oslam {

Arguments::Arguments(std::string usage, std::string description)
    : usage_(std::move(usage)), description_(std::move(description)) {}

void Arguments::AddOption(const std::string& name, const std::string& short_name,
                          const std::string& value_name, const std::string& help,
                          const std::string& default_value) {
  options_.push_back({name, short_name, value_name, help, default_value, false, false});
}

void Arguments::AddFlag(const std::string& name, const std::string& help) {
  options_.push_back({name, "", "", help, "", true, false});
}

void Arguments::AddRepeatedOption(const std::string& name, const std::string& value_name,
                                  const std::string& help) {
  options_.push_back({name, "", value_name, help + " (may be repeated)", "", false, true});
}

void Arguments::AddPositional(const std::string& name, const std::string& help, bool required) {
  positionals_.push_back({name, help, required});
}

const Arguments::Spec* Arguments::Find(const std::string& token) const {
  for (const Spec& spec : options_)
    if (token == "--" + spec.name || (!spec.short_name.empty() && token == spec.short_name))
      return &spec;
  return nullptr;
}

bool Arguments::Parse(const std::vector<std::string>& args) {
  size_t positional_index = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    std::string token = args[i];
    if (token == "--help" || token == "-h") {
      std::cout << Help();
      return false;
    }
    if (token.size() > 1 && token[0] == '-' && !(std::isdigit(token[1]) || token[1] == '.')) {
      std::string inline_value;
      bool has_inline_value = false;
      const size_t equals = token.find('=');
      if (token.rfind("--", 0) == 0 && equals != std::string::npos) {
        inline_value = token.substr(equals + 1);
        token = token.substr(0, equals);
        has_inline_value = true;
      }
      const Spec* spec = Find(token);
      if (!spec) throw UsageError("unknown option '" + token + "'");
      if (spec->is_flag) {
        if (has_inline_value) throw UsageError("option '" + token + "' takes no value");
        values_[spec->name] = "1";
      } else {
        if (!has_inline_value && i + 1 >= args.size())
          throw UsageError("option '" + token + "' needs a value");
        const std::string value = has_inline_value ? inline_value : args[++i];
        values_[spec->name] = value;
        if (spec->repeated) repeated_values_[spec->name].push_back(value);
      }
      continue;
    }
    if (positional_index >= positionals_.size())
      throw UsageError("unexpected argument '" + token + "'");
    values_[positionals_[positional_index++].name] = token;
  }
  for (size_t i = positional_index; i < positionals_.size(); ++i)
    if (positionals_[i].required) throw UsageError("missing argument " + positionals_[i].name);
  return true;
}

std::string Arguments::Help() const {
  std::ostringstream out;
  out << "usage: " << usage_ << "\n\n" << description_ << "\n";
  if (!positionals_.empty()) {
    out << "\narguments:\n";
    for (const auto& p : positionals_) out << "  " << p.name << "\n      " << p.help << "\n";
  }
  out << "\noptions:\n";
  for (const Spec& spec : options_) {
    out << "  ";
    if (!spec.short_name.empty()) out << spec.short_name << ", ";
    out << "--" << spec.name;
    if (!spec.is_flag) out << ' ' << spec.value_name;
    out << "\n      " << spec.help;
    if (!spec.default_value.empty()) out << " (default: " << spec.default_value << ")";
    out << "\n";
  }
  out << "  -h, --help\n      show this help\n";
  return out.str();
}

bool Arguments::Has(const std::string& name) const { return values_.count(name) > 0; }

std::string Arguments::Get(const std::string& name) const {
  const auto it = values_.find(name);
  if (it != values_.end()) return it->second;
  for (const Spec& spec : options_)
    if (spec.name == name) return spec.default_value;
  return "";
}

std::vector<std::string> Arguments::GetAll(const std::string& name) const {
  const auto it = repeated_values_.find(name);
  return it == repeated_values_.end() ? std::vector<std::string>() : it->second;
}

bool Arguments::Flag(const std::string& name) const { return Has(name); }

double Arguments::GetDouble(const std::string& name) const {
  const std::string text = Get(name);
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value))
    throw UsageError("--" + name + ": '" + text + "' is not a finite number");
  return value;
}

double Arguments::GetDoubleOrInfinity(const std::string& name) const {
  if (Get(name) == "inf") return std::numeric_limits<double>::infinity();
  return GetDouble(name);
}

long Arguments::GetInt(const std::string& name) const {
  const std::string text = Get(name);
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size())
    throw UsageError("--" + name + ": '" + text + "' is not an integer");
  return value;
}

}  // namespace oslam
