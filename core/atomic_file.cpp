#include "core/atomic_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>

#include "core/bounds.h"
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

std::string Reason(int error_number) {
  return error_number == ENOSPC ? "no space left on device" : std::strerror(error_number);
}

void CreateParentFolder(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) fs::create_directories(parent, ec);
  if (ec) throw Error::InFile(path, "cannot create folder: " + ec.message());
}

// A new, empty temp file beside `path`, opened for writing; its name in
// `temp_path`, and in the signal handler's `*slot` (ClaimSlot; -1 when none
// was free) from before the file exists: mkstemps fills in the name in the
// slot itself, so an interrupt at any moment finds the file it must remove.
// mkstemps' O_EXCL refuses an existing name, symlinks included.
int CreateTempFile(const std::string& path, std::string* temp_path, int* slot) {
  const fs::path target(path);
  const std::string suffix = target.extension().string();
  std::string name =
      (target.parent_path() / ("." + target.stem().string() + ".tmp-XXXXXX" + suffix)).string();
  *slot = ClaimSlot(name);
  char* const buffer = *slot >= 0 ? slot_path[*slot] : name.data();
  const int fd = ::mkstemps(buffer, static_cast<int>(suffix.size()));
  if (fd < 0) {
    const int saved = errno;
    ReleaseSlot(*slot);
    throw Error::InFile(path, "cannot create a temp file beside it: " + Reason(saved));
  }
  name = buffer;
  // mkstemps creates 0600; give the file the permissions a plain create would.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  *temp_path = name;
  return fd;
}

// Writes all of `bytes`, then fsync (when `sync`) and close; false with
// errno set on failure.
bool WriteAllAndClose(int fd, std::string_view bytes, bool sync) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int saved = n < 0 ? errno : ENOSPC;
      ::close(fd);
      errno = saved;
      return false;
    }
    done += static_cast<size_t>(n);
  }
  if (sync && ::fsync(fd) != 0) {
    const int saved = errno;
    ::close(fd);
    errno = saved;
    return false;
  }
  return ::close(fd) == 0;
}

// Makes a rename in the folder durable; best effort (some file systems refuse).
void SyncFolderOf(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  const int fd = ::open(parent.empty() ? "." : parent.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// Runs `write` on the path of a new in-memory file and returns the bytes it
// wrote (see WriteAtomically); `path`, the target, names the errors.
std::string WrittenInMemory(const std::string& path,
                            const std::function<void(const std::string&)>& write) {
  const int fd = ::memfd_create("oslam-output", MFD_CLOEXEC);
  if (fd < 0) throw Error::InFile(path, "cannot create an in-memory file: " + Reason(errno));
  const struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  write("/proc/self/fd/" + std::to_string(fd));
  struct stat status {};
  if (::fstat(fd, &status) != 0) throw Error::InFile(path, "write failed: " + Reason(errno));
  const auto size = static_cast<rlim_t>(status.st_size);
  rlimit limit{};
  if (::getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY &&
      size >= limit.rlim_cur)
    throw Error::InFile(path, "write failed: the file reaches the file size limit (ulimit -f)");
  if (size == 0) throw Error::InFile(path, "nothing was written");
  std::string bytes(static_cast<size_t>(size), '\0');
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n =
        ::pread(fd, bytes.data() + done, bytes.size() - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw Error::InFile(path, "cannot read back what was written: " + Reason(errno));
    done += static_cast<size_t>(n);
  }
  return bytes;
}

}  // namespace

void WriteAtomically(const std::string& path,
                     const std::function<void(const std::string& memory_path)>& write) {
  WriteFileAtomically(path, WrittenInMemory(path, write));
}

void InstallInterruptCleanup() {
  std::signal(SIGINT, RemoveTempFilesAndDie);
  std::signal(SIGTERM, RemoveTempFilesAndDie);
}

void WriteFileAtomically(const std::string& path, std::string_view bytes, FileSync sync) {
  CreateParentFolder(path);
  std::string temp_path;
  int slot = -1;
  const int fd = CreateTempFile(path, &temp_path, &slot);
  const auto fail = [&](const std::string& what) {
    ::unlink(temp_path.c_str());
    ReleaseSlot(slot);
    throw Error::InFile(path, what);
  };
  if (!WriteAllAndClose(fd, bytes, sync == FileSync::kEach)) fail("write failed: " + Reason(errno));
  if (::rename(temp_path.c_str(), path.c_str()) != 0)
    fail("cannot move the written file into place: " + Reason(errno));
  ReleaseSlot(slot);
  if (sync == FileSync::kEach) SyncFolderOf(path);
}

void SyncFileSystem(const std::string& folder) {
  const int fd = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) throw Error::InFile(folder, "cannot open the folder: " + Reason(errno));
  const bool synced = ::syncfs(fd) == 0;
  const int saved = errno;
  ::close(fd);
  if (!synced) throw Error::InFile(folder, "flushing the written files failed: " + Reason(saved));
}

void WriteTextFileAtomically(const std::string& path, const std::string& contents) {
  WriteFileAtomically(path, contents);
}

void CheckOutputSubfolder(const std::string& root, const std::string& name) {
  const fs::path folder = fs::path(root) / name;
  std::error_code ec;
  if (fs::is_symlink(folder, ec)) {
    const fs::path target = fs::weakly_canonical(folder, ec);
    const fs::path inside = fs::weakly_canonical(root, ec);
    const auto mismatch = std::mismatch(inside.begin(), inside.end(), target.begin(), target.end());
    if (mismatch.first != inside.end() || target == inside)
      throw Error::InFile(folder.string(), "a symlink to " + target.string() +
                                               ", out of the output folder; remove it or "
                                               "choose another output folder");
  }
}

std::string PrepareOutputFolder(const std::string& root, const std::string& name) {
  CheckOutputSubfolder(root, name);
  const fs::path folder = fs::path(root) / name;
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (!fs::is_directory(folder)) throw Error::InFile(folder.string(), "cannot create the folder");
  return folder.string();
}

void CheckInputFile(const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) throw Error::InFile(path, "file not found");
  if (!fs::is_regular_file(status)) throw Error::InFile(path, "not a regular file");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > static_cast<std::uintmax_t>(bounds::kFileBytes))
    throw Error::InFile(path, "larger than " + std::to_string(bounds::kFileBytes >> 20) +
                                  " MiB (docs/formats.md, Bounds)");
}

std::string ReadTextFile(const std::string& path) {
  CheckInputFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error::InFile(path, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream contents;
  contents << in.rdbuf();
  if (in.bad()) throw Error::InFile(path, "read failed");
  return contents.str();
}

}  // namespace oslam
