// Atomic, durable output: the target is either the old file or the whole new
// one, never a part, and no temp file is left behind, also on a full disk.
#include "core/atomic_file.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;

std::string Read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

int FilesIn(const std::string& folder) {
  int count = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(folder)) ++count;
  return count;
}

TEST(AtomicFile, WritesTheBytesAndLeavesNoTempFile) {
  testing::TempDir dir;
  const std::string path = dir.Path("out/map.json");
  const std::string bytes("{\"a\": 1}\n\0binary", 16);
  WriteFileAtomically(path, bytes);
  EXPECT_EQ(Read(path), bytes);
  EXPECT_EQ(FilesIn(dir.Path("out")), 1);
  WriteTextFileAtomically(path, "second");
  EXPECT_EQ(Read(path), "second");
  EXPECT_EQ(FilesIn(dir.Path("out")), 1);
}

TEST(AtomicFile, NewFilesGetTheUmaskPermissions) {
  testing::TempDir dir;
  const mode_t old_mask = ::umask(022);
  WriteFileAtomically(dir.Path("a.txt"), "x");
  ::umask(old_mask);
  const fs::perms perms = fs::status(dir.Path("a.txt")).permissions();
  EXPECT_EQ(perms & fs::perms::all, fs::perms(0644));
}

TEST(AtomicFile, ASymlinkAtTheTargetIsReplacedNotFollowed) {
  testing::TempDir dir;
  const std::string victim = dir.Path("outside.txt");
  WriteTextFileAtomically(victim, "keep me");
  fs::create_directories(dir.Path("out"));
  fs::create_symlink(victim, dir.Path("out/eval.json"));
  WriteTextFileAtomically(dir.Path("out/eval.json"), "new");
  EXPECT_EQ(Read(victim), "keep me");
  EXPECT_FALSE(fs::is_symlink(dir.Path("out/eval.json")));
  EXPECT_EQ(Read(dir.Path("out/eval.json")), "new");
}

// Runs `write` in a child process whose files may not grow beyond
// `limit_bytes` (RLIMIT_FSIZE: writes beyond it fail as on a full disk).
// Returns the child's exit code: 0 written, 1 oslam::Error, 2 anything else.
int WriteWithFileSizeLimit(rlim_t limit_bytes, const std::function<void()>& write) {
  const pid_t child = ::fork();
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);  // fail the write instead of killing the process
    const rlimit limit{limit_bytes, limit_bytes};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    int code = 0;
    try {
      write();
    } catch (const Error&) {
      code = 1;
    } catch (...) {
      code = 2;
    }
    ::_exit(code);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(AtomicFile, AFullDiskLeavesTheOldFileAndNoTempFile) {
  testing::TempDir dir;
  const std::string path = dir.Path("classes.yaml");
  WriteTextFileAtomically(path, "old contents");
  const std::string big(64 * 1024, 'x');
  EXPECT_EQ(WriteWithFileSizeLimit(4096, [&] { WriteFileAtomically(path, big); }), 1);
  EXPECT_EQ(Read(path), "old contents");
  EXPECT_EQ(FilesIn(dir.Path()), 1);
}

TEST(AtomicFile, AFailedWriteThroughACallbackReachesNoFinalName) {
  testing::TempDir dir;
  const std::string path = dir.Path("image.bin");
  const std::string big(64 * 1024, 'y');
  // A writer that checks its stream: the failure propagates, and nothing
  // reaches the final name.
  const int code = WriteWithFileSizeLimit(4096, [&] {
    WriteAtomically(path, [&](const std::string& temp) {
      std::ofstream out(temp, std::ios::binary);
      out << big;
      if (!out) throw Error::InFile(path, "write failed");
    });
  });
  EXPECT_EQ(code, 1);
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(FilesIn(dir.Path()), 0);
}

// A library writer that ignores its stream's state (as tinygltf's and PCL's
// file writers do): WriteAtomically must still not put a cut-short file
// under the final name.
void UncheckedWrite(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

TEST(AtomicFile, AWriterThatIgnoresItsFailuresCannotCutTheFileShort) {
  testing::TempDir dir;
  const std::string path = dir.Path("map.ply");
  const std::string big(64 * 1024, 'z');
  WriteAtomically(path, [&](const std::string& memory) { UncheckedWrite(memory, big); });
  EXPECT_EQ(Read(path), big);
  WriteTextFileAtomically(path, "old contents");
  const int code = WriteWithFileSizeLimit(4096, [&] {
    WriteAtomically(path, [&](const std::string& memory) { UncheckedWrite(memory, big); });
  });
  EXPECT_EQ(code, 1);
  EXPECT_EQ(Read(path), "old contents");
  EXPECT_EQ(FilesIn(dir.Path()), 1);
}

TEST(AtomicFile, AWriterThatWritesNothingIsAnError) {
  testing::TempDir dir;
  const std::string path = dir.Path("empty.png");
  WriteTextFileAtomically(path, "old");
  EXPECT_THROW(WriteAtomically(path, [](const std::string&) {}), Error);
  EXPECT_EQ(Read(path), "old");
  EXPECT_EQ(FilesIn(dir.Path()), 1);
}

TEST(AtomicFile, AnUnwritableFolderIsAnErrorNamingTheFile) {
  testing::TempDir dir;
  WriteTextFileAtomically(dir.Path("plain"), "a file, not a folder");
  try {
    WriteTextFileAtomically(dir.Path("plain/x.json"), "x");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("plain/x.json"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace oslam
