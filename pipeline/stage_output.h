// What a stage says while it runs: progress lines on stderr (core/progress.h)
// unless quiet, the lines of its report (what a command prints on stdout)
// and warnings through the caller's callbacks.
#pragma once

#include <functional>
#include <string>

namespace oslam {

struct StageOutput {
  bool quiet = false;  // no progress and no report lines; warnings still
  std::function<void(const std::string& line)> print;    // one line, no newline; null: dropped
  std::function<void(const std::string& message)> warn;  // null: dropped

  void Print(const std::string& line) const {
    if (!quiet && print) print(line);
  }
  void Warn(const std::string& message) const {
    if (warn) warn(message);
  }
};

}  // namespace oslam
