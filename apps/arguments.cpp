#include "apps/arguments.h"

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "core/error.h"

namespace oslam {
namespace {

// "-x" and "--x" are options, "-3" and "-.5" are values.
bool IsOption(const std::string& token) {
  return token.size() > 1 && token[0] == '-' &&
         !(std::isdigit(static_cast<unsigned char>(token[1])) || token[1] == '.');
}

// "--name=value" -> "--name" and true with the value; else the token.
std::string OptionPart(const std::string& token, std::string* inline_value, bool* has_inline) {
  const size_t equals = token.find('=');
  *has_inline = token.rfind("--", 0) == 0 && equals != std::string::npos;
  if (!*has_inline) return token;
  *inline_value = token.substr(equals + 1);
  return token.substr(0, equals);
}

}  // namespace

Arguments::Arguments(std::string usage, std::string description)
    : usage_(std::move(usage)), description_(std::move(description)) {}

void Arguments::AddOption(const std::string& name, const std::string& short_name,
                          const std::string& value_name, const std::string& help,
                          const std::string& default_value) {
  options_.push_back({name, short_name, value_name, help, default_value, false, false,
                      static_cast<int>(modes_.size()) - 1});
}

void Arguments::AddFlag(const std::string& name, const std::string& help) {
  options_.push_back({name, "", "", help, "", true, false, static_cast<int>(modes_.size()) - 1});
}

void Arguments::AddRepeatedOption(const std::string& name, const std::string& value_name,
                                  const std::string& help) {
  options_.push_back({name, "", value_name, help + " (may be repeated)", "", false, true,
                      static_cast<int>(modes_.size()) - 1});
}

void Arguments::AddPositional(const std::string& name, const std::string& help, bool required) {
  positionals_.push_back({name, help, required, static_cast<int>(modes_.size()) - 1});
}

void Arguments::BeginMode(const std::string& selector, const std::string& title,
                          const std::string& usage, const std::string& description) {
  modes_.push_back({selector, title, usage, description});
}

const Arguments::Spec* Arguments::Find(const std::string& token, int mode) const {
  for (const Spec& spec : options_)
    if ((spec.mode == -1 || spec.mode == mode) &&
        (token == "--" + spec.name || (!spec.short_name.empty() && token == spec.short_name)))
      return &spec;
  return nullptr;
}

const Arguments::Spec* Arguments::FindAny(const std::string& token) const {
  for (const Spec& spec : options_)
    if (token == "--" + spec.name || (!spec.short_name.empty() && token == spec.short_name))
      return &spec;
  return nullptr;
}

// The mode whose selector is given (the one without a selector when none
// is); a first pass over the options, skipping their values.
int Arguments::ChooseMode(const std::vector<std::string>& args, bool* help) const {
  int chosen = -1, default_mode = -1;
  for (size_t m = 0; m < modes_.size(); ++m)
    if (modes_[m].selector.empty()) default_mode = static_cast<int>(m);
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") *help = true;
    if (!IsOption(args[i])) continue;
    std::string value;
    bool has_inline = false;
    const Spec* spec = FindAny(OptionPart(args[i], &value, &has_inline));
    if (!spec) continue;
    if (!spec->is_flag && !has_inline) ++i;  // its value
    if (spec->mode < 0 || modes_[spec->mode].selector != spec->name) continue;
    if (chosen >= 0 && chosen != spec->mode)
      throw UsageError("--" + modes_[chosen].selector + " and --" + spec->name +
                       " exclude each other");
    chosen = spec->mode;
  }
  return chosen >= 0 ? chosen : default_mode;
}

// Why `token` (an option of another mode) is refused.
std::string Arguments::OtherModeProblem(const std::string& token, const Spec& spec) const {
  std::string selectors;
  bool in_default_mode = false;
  for (const Spec& other : options_) {
    if (other.name != spec.name || other.mode < 0) continue;
    const std::string& selector = modes_[other.mode].selector;
    if (selector.empty())
      in_default_mode = true;
    else
      selectors += (selectors.empty() ? "--" : " or --") + selector;
  }
  if (!selectors.empty() && !in_default_mode) return "option '" + token + "' needs " + selectors;
  return "option '" + token + "' does not apply with --" + modes_[mode_index_].selector;
}

bool Arguments::Parse(const std::vector<std::string>& args) {
  bool help = false;
  mode_index_ = ChooseMode(args, &help);
  mode_ = mode_index_ >= 0 ? modes_[mode_index_].selector : "";
  if (help) {
    const bool selected = mode_index_ >= 0 && !mode_.empty();
    std::cout << (selected ? ModeHelp(mode_index_) : Help());
    return false;
  }
  std::vector<const PositionalSpec*> positionals;
  for (const PositionalSpec& p : positionals_)
    if (p.mode == -1 || p.mode == mode_index_) positionals.push_back(&p);
  size_t positional_index = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    if (IsOption(args[i])) {
      std::string inline_value;
      bool has_inline_value = false;
      const std::string token = OptionPart(args[i], &inline_value, &has_inline_value);
      const Spec* spec = Find(token, mode_index_);
      if (!spec) {
        const Spec* other = FindAny(token);
        throw UsageError(other ? OtherModeProblem(token, *other)
                               : "unknown option '" + token + "'");
      }
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
    if (positional_index >= positionals.size())
      throw UsageError("unexpected argument '" + args[i] + "'");
    values_[positionals[positional_index++]->name] = args[i];
  }
  for (size_t i = positional_index; i < positionals.size(); ++i)
    if (positionals[i]->required) throw UsageError("missing argument " + positionals[i]->name);
  return true;
}

void Arguments::AppendOption(std::ostream& out, const Spec& spec) const {
  out << "  ";
  if (!spec.short_name.empty()) out << spec.short_name << ", ";
  out << "--" << spec.name;
  if (!spec.is_flag) out << ' ' << spec.value_name;
  out << "\n      " << spec.help;
  if (!spec.default_value.empty()) out << " (default: " << spec.default_value << ")";
  out << "\n";
}

std::string Arguments::ModeHelp(int mode) const {
  const bool own = mode >= 0 && !modes_[mode].usage.empty();
  std::ostringstream out;
  out << "usage: " << (own ? modes_[mode].usage : usage_) << "\n\n"
      << (own ? modes_[mode].description : description_) << "\n";
  bool any_positional = false;
  for (const PositionalSpec& p : positionals_) {
    if (p.mode != -1 && p.mode != mode) continue;
    if (!any_positional) out << "\narguments:\n";
    any_positional = true;
    out << "  " << p.name << "\n      " << p.help << "\n";
  }
  out << "\noptions:\n";
  for (const Spec& spec : options_)
    if (spec.mode == -1 || spec.mode == mode) AppendOption(out, spec);
  out << "  -h, --help\n      show this help\n";
  return out.str();
}

std::string Arguments::Help() const {
  if (modes_.empty()) return ModeHelp(-1);
  std::ostringstream out;
  out << "usage: " << usage_ << "\n\n" << description_ << "\n\noptions of every mode:\n";
  for (const Spec& spec : options_)
    if (spec.mode == -1) AppendOption(out, spec);
  out << "  -h, --help\n      show this help\n";
  for (size_t m = 0; m < modes_.size(); ++m) {
    out << "\n" << modes_[m].title << ":\n";
    for (const PositionalSpec& p : positionals_)
      if (p.mode == static_cast<int>(m)) out << "  " << p.name << "\n      " << p.help << "\n";
    for (const Spec& spec : options_)
      if (spec.mode == static_cast<int>(m)) AppendOption(out, spec);
  }
  return out.str();
}

bool Arguments::Has(const std::string& name) const {
  return values_.count(name) > 0;
}

std::string Arguments::Get(const std::string& name) const {
  const auto it = values_.find(name);
  if (it != values_.end()) return it->second;
  for (const Spec& spec : options_)
    if (spec.name == name && (spec.mode == -1 || spec.mode == mode_index_))
      return spec.default_value;
  return "";
}

std::vector<std::string> Arguments::GetAll(const std::string& name) const {
  const auto it = repeated_values_.find(name);
  return it == repeated_values_.end() ? std::vector<std::string>() : it->second;
}

bool Arguments::Flag(const std::string& name) const {
  return Has(name);
}

double Arguments::GetDouble(const std::string& name) const {
  const std::string text = Get(name);
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value))
    throw UsageError("--" + name + ": '" + text + "' is not a finite number");
  return value;
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
