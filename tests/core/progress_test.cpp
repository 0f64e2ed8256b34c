// Progress lines on stderr: one closing line when stderr is a file, a line
// updated in place (at most every 100 ms, always at the end) on a terminal,
// nothing when quiet. stderr is pointed at a file or at a pseudo-terminal for
// each test and read back.
#include "core/progress.h"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "test_util.h"

namespace oslam {
namespace {

// Points stderr (fd 2) at `fd` until destroyed.
class RedirectStderr {
 public:
  explicit RedirectStderr(int fd) : saved_(::dup(STDERR_FILENO)) {
    std::fflush(stderr);
    ::dup2(fd, STDERR_FILENO);
  }
  ~RedirectStderr() {
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
  }
  RedirectStderr(const RedirectStderr&) = delete;
  RedirectStderr& operator=(const RedirectStderr&) = delete;

 private:
  int saved_;
};

// What `body` writes to stderr when stderr is a regular file.
template <typename Body>
std::string StderrToFile(Body body) {
  testing::TempDir dir;
  const std::string path = dir.Path("stderr.txt");
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  EXPECT_GE(fd, 0);
  {
    RedirectStderr redirect(fd);
    body();
  }
  ::close(fd);
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A pseudo-terminal in raw mode (no "\n" -> "\r\n"): stderr pointed at its
// terminal side is a terminal for isatty(), and Read() returns what was
// written to it since the last Read().
class PseudoTerminal {
 public:
  PseudoTerminal() {
    master_ = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0) return;
    const char* name = ::ptsname(master_);
    if (!name) return;
    terminal_ = ::open(name, O_RDWR | O_NOCTTY);
    if (terminal_ < 0) return;
    termios raw;
    ::tcgetattr(terminal_, &raw);
    ::cfmakeraw(&raw);
    ::tcsetattr(terminal_, TCSANOW, &raw);
    ::fcntl(master_, F_SETFL, ::fcntl(master_, F_GETFL) | O_NONBLOCK);
  }
  ~PseudoTerminal() {
    if (terminal_ >= 0) ::close(terminal_);
    if (master_ >= 0) ::close(master_);
  }
  bool ok() const { return terminal_ >= 0; }
  int terminal() const { return terminal_; }
  std::string Read() {
    std::string out;
    char buffer[4096];
    for (ssize_t n; (n = ::read(master_, buffer, sizeof(buffer))) > 0;) out.append(buffer, n);
    return out;
  }

 private:
  int master_ = -1, terminal_ = -1;
};

TEST(Progress, ToAFileOnlyDonePrintsOneClosingLineWithTheSummary) {
  const std::string out = StderrToFile([] {
    Progress progress("detect", 150, "frames", false);
    for (size_t done = 0; done <= 150; ++done) progress.Update(done);
    progress.Done("12 detections");
  });
  EXPECT_TRUE(
      std::regex_match(out, std::regex(R"(\[detect\] 150 frames in \d+\.\d\d s: 12 detections\n)")))
      << out;
}

TEST(Progress, WithoutASummaryTheLineEndsAtTheTime) {
  const std::string out = StderrToFile([] {
    Progress progress("map", 3, "solves", false);
    progress.Done();
  });
  EXPECT_TRUE(std::regex_match(out, std::regex(R"(\[map\] 3 solves in \d+\.\d\d s\n)"))) << out;
}

TEST(Progress, TheDestructorClosesAnUnfinishedLineAndDoneCountsOnce) {
  const std::string unfinished =
      StderrToFile([] { Progress progress("export", 4, "files", false); });
  EXPECT_TRUE(std::regex_match(unfinished, std::regex(R"(\[export\] 4 files in \d+\.\d\d s\n)")))
      << unfinished;
  const std::string twice = StderrToFile([] {
    Progress progress("export", 4, "files", false);
    progress.Done("first");
    progress.Done("second");
  });
  EXPECT_TRUE(std::regex_match(twice, std::regex(R"(\[export\] 4 files in \d+\.\d\d s: first\n)")))
      << twice;
}

TEST(Progress, QuietPrintsNothingToAFileOrATerminal) {
  EXPECT_EQ(StderrToFile([] {
              Progress progress("detect", 10, "frames", true);
              progress.Update(10);
              progress.Done("summary");
            }),
            "");
  EXPECT_EQ(StderrToFile([] { Progress progress("detect", 10, "frames", true); }), "");
  PseudoTerminal terminal;
  if (!terminal.ok()) GTEST_SKIP() << "no pseudo-terminal available";
  {
    RedirectStderr redirect(terminal.terminal());
    Progress progress("detect", 10, "frames", true);
    std::this_thread::sleep_for(std::chrono::milliseconds(120));
    progress.Update(5);
    progress.Update(10);
    progress.Done("summary");
  }
  EXPECT_EQ(terminal.Read(), "");
}

TEST(Progress, OnATerminalOneLineIsRewrittenAtMostEvery100MsAndClosedByDone) {
  PseudoTerminal terminal;
  if (!terminal.ok()) GTEST_SKIP() << "no pseudo-terminal available";
  RedirectStderr redirect(terminal.terminal());
  Progress progress("detect", 10, "frames", false);
  // Within 100 ms of the start (or of the last line) an update is skipped...
  progress.Update(1);
  EXPECT_EQ(terminal.Read(), "");
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  // ...after it, the line is redrawn from its start, with no newline.
  progress.Update(5);
  const std::string half = terminal.Read();
  std::smatch match;
  ASSERT_TRUE(std::regex_match(
      half, match, std::regex(R"(\r\[detect\] 5/10 frames  (\d+\.\d) s  ETA (\d+\.\d) s   )")))
      << half;
  const double elapsed = std::stod(match[1]), eta = std::stod(match[2]);
  EXPECT_GE(elapsed, 0.1);
  // Half done: the remaining half should take as long as the first.
  EXPECT_NEAR(eta, elapsed, 0.1 + 1e-9);
  progress.Update(6);
  EXPECT_EQ(terminal.Read(), "");
  // The last update is always shown, with nothing left to wait for.
  progress.Update(10);
  EXPECT_TRUE(std::regex_match(
      terminal.Read(), std::regex(R"(\r\[detect\] 10/10 frames  \d+\.\d s  ETA 0\.0 s   )")));
  // Done clears the line and leaves the closing one.
  progress.Done("3 detections");
  const std::string done = terminal.Read();
  EXPECT_TRUE(std::regex_match(
      done, std::regex("\r\033\\[K\\[detect\\] 10 frames in \\d+\\.\\d\\d s: 3 detections\n")))
      << done;
}

}  // namespace
}  // namespace oslam
