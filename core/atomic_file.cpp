#include "core/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace oslam {
namespace fs = std::filesystem;

namespace {

std::string TempPathFor(const std::string& path) {
  const fs::path target(path);
  // Unique per process so two writers never share a temp file.
  const std::string stem = "." + target.stem().string() + ".tmp" + std::to_string(::getpid());
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
  try {
    write(temp_path);
    if (!fs::exists(temp_path)) throw Error::InFile(path, "nothing was written");
    fs::rename(temp_path, path, ec);
    if (ec) throw Error::InFile(path, "cannot move the written file into place: " + ec.message());
  } catch (...) {
    fs::remove(temp_path, ec);
    throw;
  }
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
