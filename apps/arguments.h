// Command-line arguments of one subcommand: options declared up front, so
// --help is generated and anything undeclared is a usage error (exit 2).
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

  // Returns false when --help was given (help already printed to stdout).
  // Throws oslam::UsageError on anything else that is wrong.
  bool Parse(const std::vector<std::string>& args);

  std::string Help() const;
  bool Has(const std::string& name) const;  // given on the command line (or positional present)
  std::string Get(const std::string& name) const;  // value, default, or ""
  bool Flag(const std::string& name) const;
  double GetDouble(const std::string& name) const;  // UsageError when not a number
  // The same, but "inf" is allowed (limits and penalties that may be off).
  double GetDoubleOrInfinity(const std::string& name) const;
  long GetInt(const std::string& name) const;
  std::vector<std::string> GetAll(const std::string& name) const;

 private:
  struct Spec {
    std::string name, short_name, value_name, help, default_value;
    bool is_flag = false;
    bool repeated = false;
  };
  struct PositionalSpec {
    std::string name, help;
    bool required = true;
  };
  const Spec* Find(const std::string& token) const;

  std::string usage_, description_;
  std::vector<Spec> options_;
  std::vector<PositionalSpec> positionals_;
  std::map<std::string, std::string> values_;
  std::map<std::string, std::vector<std::string>> repeated_values_;
};

}  // namespace oslam
