// Errors raised at the input boundary. One line, naming where and what.
#pragma once

#include <stdexcept>
#include <string>

namespace oslam {

// A runtime error the user can act on (bad file, bad value). The CLI prints
// what() on one line and exits with code 1.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}

  // "FILE: what"
  static Error InFile(const std::string& path, const std::string& what);
  // "FILE:LINE: what"
  static Error AtLine(const std::string& path, int line, const std::string& what);
};

// Wrong command-line usage. The CLI exits with code 2.
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace oslam
