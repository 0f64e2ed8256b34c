// Command-line arguments of one subcommand: options declared up front, so
// --help is generated and anything undeclared is a usage error (exit 2).
//
// A command may have modes: one option, the mode's selector (a flag such as
// --known-association, or an option with a value such as --landmarks FILE),
// chooses the mode, and the options and arguments declared for a mode are
// accepted only in it; those declared before the first mode are common to
// all. One mode may have no selector: it applies when no selector is given.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace oslam {

class Arguments {
 public:
  // `usage` is the synopsis line, e.g. "oslam camera [options]".
  Arguments(std::string usage, std::string description);

  // --name VALUE (also --name=VALUE); `short_name` like "-o" or "".
  void AddOption(const std::string& name, const std::string& short_name,
                 const std::string& value_name, const std::string& help,
                 const std::string& default_value = "");
  void AddFlag(const std::string& name, const std::string& help);
  // An option that may be given several times; GetAll returns every value.
  void AddRepeatedOption(const std::string& name, const std::string& value_name,
                         const std::string& help);
  void AddPositional(const std::string& name, const std::string& help, bool required = true);

  // Starts the declarations of a mode. `selector` is the name of the
  // option (declared next, in the mode) that chooses it, "" for the mode
  // without one; `title` heads its options in --help; `usage` and
  // `description` replace the command's in `--help` given with the selector.
  void BeginMode(const std::string& selector, const std::string& title, const std::string& usage,
                 const std::string& description);

  // Returns false when --help was given (help already printed to stdout).
  // Throws oslam::UsageError on anything else that is wrong, naming the
  // mode an option belongs to when it is given in another.
  bool Parse(const std::vector<std::string>& args);

  // The whole help: with modes, every mode's options under its title.
  std::string Help() const;
  // The selector of the mode chosen by Parse ("" = the mode without one).
  const std::string& mode() const { return mode_; }

  bool Has(const std::string& name) const;  // given on the command line (or positional present)
  std::string Get(const std::string& name) const;  // value, default, or ""
  bool Flag(const std::string& name) const;
  double GetDouble(const std::string& name) const;  // UsageError when not a number
  long GetInt(const std::string& name) const;
  std::vector<std::string> GetAll(const std::string& name) const;

 private:
  struct Spec {
    std::string name, short_name, value_name, help, default_value;
    bool is_flag = false;
    bool repeated = false;
    int mode = -1;  // index into modes_, -1 = common
  };
  struct PositionalSpec {
    std::string name, help;
    bool required = true;
    int mode = -1;
  };
  struct Mode {
    std::string selector, title, usage, description;
  };
  // The spec `token` names among those of `mode` and the common ones.
  const Spec* Find(const std::string& token, int mode) const;
  // Any spec `token` names, in whatever mode.
  const Spec* FindAny(const std::string& token) const;
  int ChooseMode(const std::vector<std::string>& args, bool* help) const;
  std::string OtherModeProblem(const std::string& token, const Spec& spec) const;
  // The help of one mode alone, as a command without modes has it.
  std::string ModeHelp(int mode) const;
  void AppendOption(std::ostream& out, const Spec& spec) const;

  std::string usage_, description_;
  std::vector<Spec> options_;
  std::vector<PositionalSpec> positionals_;
  std::vector<Mode> modes_;
  std::string mode_;
  int mode_index_ = -1;  // into modes_, -1 = none
  std::map<std::string, std::string> values_;
  std::map<std::string, std::vector<std::string>> repeated_values_;
};

}  // namespace oslam
