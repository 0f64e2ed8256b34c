// One progress line per stage on stderr: updated in place on a terminal
// ("[detect] 120/150 frames  3.1 s  ETA 0.8 s"), a single closing line when
// stderr is a file, nothing when quiet.
#pragma once

#include <chrono>
#include <string>

namespace oslam {

class Progress {
 public:
  Progress(std::string stage, size_t total, std::string unit, bool quiet);
  ~Progress();  // finishes the line if Done() was not called
  void Update(size_t done);
  void Done(const std::string& summary = "");

 private:
  double ElapsedSeconds() const;

  std::string stage_, unit_;
  size_t total_ = 0;
  bool quiet_ = false, terminal_ = false, finished_ = false;
  std::chrono::steady_clock::time_point start_, last_print_;
};

}  // namespace oslam
