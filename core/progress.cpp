#include "core/progress.h"

#include <unistd.h>

#include <cstdio>

namespace oslam {

Progress::Progress(std::string stage, size_t total, std::string unit, bool quiet)
    : stage_(std::move(stage)),
      unit_(std::move(unit)),
      total_(total),
      quiet_(quiet),
      terminal_(::isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_print_(start_) {}

Progress::~Progress() {
  if (!finished_) Done();
}

double Progress::ElapsedSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::Update(size_t done) {
  if (quiet_ || !terminal_) return;
  const auto now = std::chrono::steady_clock::now();
  if (done < total_ && now - last_print_ < std::chrono::milliseconds(100)) return;
  last_print_ = now;
  const double elapsed = ElapsedSeconds();
  const double eta = done > 0 ? elapsed * (total_ - done) / done : 0.0;
  std::fprintf(stderr, "\r[%s] %zu/%zu %s  %.1f s  ETA %.1f s   ", stage_.c_str(), done, total_,
               unit_.c_str(), elapsed, eta);
  std::fflush(stderr);
}

void Progress::Done(const std::string& summary) {
  if (finished_) return;
  finished_ = true;
  if (quiet_) return;
  std::fprintf(stderr, "%s[%s] %zu %s in %.2f s%s%s\n", terminal_ ? "\r\033[K" : "", stage_.c_str(),
               total_, unit_.c_str(), ElapsedSeconds(), summary.empty() ? "" : ": ",
               summary.c_str());
}

}  // namespace oslam
