#include "core/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace oslam {
namespace fs = std::filesystem;

namespace {

// Temp files of writes under way, for the signal handler. A signal handler
// can only touch lock-free data, hence fixed slots claimed with atomics; this
// is the one piece of global state in oslam, and only signals read it.
constexpr int kSlots = 64;
constexpr size_t kPathLength = 4096;
std::atomic<bool> slot_used[kSlots];
char slot_path[kSlots][kPathLength];

int ClaimSlot(const std::string& temp_path) {
  if (temp_path.size() >= kPathLength) return -1;
  for (int i = 0; i < kSlots; ++i) {
    bool expected = false;
    if (slot_used[i].compare_exchange_strong(expected, true)) {
      std::memcpy(slot_path[i], temp_path.c_str(), temp_path.size() + 1);
      return i;
    }
  }
  return -1;  // more concurrent writes than slots: that write is not cleaned up
}

void ReleaseSlot(int slot) {
  if (slot >= 0) slot_used[slot].store(false);
}

extern "C" void RemoveTempFilesAndDie(int signal_number) {
  for (int i = 0; i < kSlots; ++i)
    if (slot_used[i].load()) ::unlink(slot_path[i]);
  std::signal(signal_number, SIG_DFL);
  std::raise(signal_number);
}

std::string TempPathFor(const std::string& path) {
  const fs::path target(path);
  // Unique per process and write, so two writers never share a temp file.
  static std::atomic<unsigned> counter{0};
  const std::string stem = "." + target.stem().string() + ".tmp" + std::to_string(::getpid()) +
                           "-" + std::to_string(counter++);
  return (target.parent_path() / (stem + target.extension().string())).string();
}

}  // namespace

void WriteAtomically(const std::string& path,
                     const std::function<void(const std::string& temp_path)>& write) {
  const fs::path parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) fs::create_directories(parent, ec);
  if (ec) throw Error::InFile(path, "cannot create folder: " + ec.message());
  const std::string temp_path = TempPathFor(path);
  const int slot = ClaimSlot(temp_path);
  try {
    write(temp_path);
    if (!fs::exists(temp_path)) throw Error::InFile(path, "nothing was written");
    fs::rename(temp_path, path, ec);
    if (ec) throw Error::InFile(path, "cannot move the written file into place: " + ec.message());
  } catch (...) {
    fs::remove(temp_path, ec);
    ReleaseSlot(slot);
    throw;
  }
  ReleaseSlot(slot);
}

void InstallInterruptCleanup() {
  std::signal(SIGINT, RemoveTempFilesAndDie);
  std::signal(SIGTERM, RemoveTempFilesAndDie);
}

void WriteTextFileAtomically(const std::string& path, const std::string& contents) {
  WriteAtomically(path, [&](const std::string& temp_path) {
    std::ofstream out(temp_path, std::ios::binary);
    if (!out) throw Error::InFile(path, std::string("cannot open for writing: ") + std::strerror(errno));
    out << contents;
    out.close();
    if (!out) throw Error::InFile(path, "write failed (disk full?)");
  });
}

std::string ReadTextFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error::InFile(path, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream contents;
  contents << in.rdbuf();
  return contents.str();
}

}  // namespace oslam
