#include "pipeline/run_status.h"

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// FNV-1a, 64 bits: stable across builds and machines, unlike std::hash.
class Fnv {
 public:
  void Add(const std::string& text) {
    for (const unsigned char c : text) hash_ = (hash_ ^ c) * 0x100000001b3ull;
    hash_ = (hash_ ^ 0xFF) * 0x100000001b3ull;  // separator
  }
  std::string Hex() const {
    char text[17];
    std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash_));
    return text;
  }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ull;
};

// Name, size and modification time of a file (or "absent").
void AddFile(const fs::path& path, const fs::path& base, Fnv* hash) {
  std::error_code ec;
  hash->Add(fs::relative(path, base, ec).string());
  const auto size = fs::file_size(path, ec);
  if (ec) {
    hash->Add("absent");
    return;
  }
  const auto time = fs::last_write_time(path, ec).time_since_epoch().count();
  hash->Add(std::to_string(size) + "/" + std::to_string(time));
}

// The regular files of `folder`, sorted (none when it is absent).
std::vector<fs::path> FilesOf(const fs::path& folder) {
  std::vector<fs::path> files;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return files;
  for (const auto& entry : fs::directory_iterator(folder, ec))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

bool IsFolder(const std::string& file) {
  return !file.empty() && file.back() == '/';
}

// An overlay image's name: six digits and ".png" or ".jpg".
bool IsNumberedImage(const std::string& name) {
  return name.size() == 10 &&
         (name.compare(6, 4, ".png") == 0 || name.compare(6, 4, ".jpg") == 0) &&
         std::all_of(name.begin(), name.begin() + 6, [](char c) { return c >= '0' && c <= '9'; });
}

// Removes a stage's file, or a folder's numbered images (and the folder when
// that empties it); a symlinked folder is left alone, never followed.
void Remove(const fs::path& out, const std::string& file) {
  std::error_code ec;
  if (!IsFolder(file)) {
    const fs::path path = out / file;
    if (fs::is_symlink(path, ec) || fs::exists(path, ec)) fs::remove(path, ec);
    if (ec)
      throw Error::InFile(path.string(), "cannot remove the previous run's file: " + ec.message());
    return;
  }
  const fs::path folder = out / file.substr(0, file.size() - 1);
  if (fs::is_symlink(folder, ec) || !fs::is_directory(folder, ec)) return;
  for (const fs::path& image : FilesOf(folder))
    if (IsNumberedImage(image.filename().string())) fs::remove(image, ec);
  if (fs::is_empty(folder, ec)) fs::remove(folder, ec);
}

bool Present(const fs::path& out, const std::string& file) {
  std::error_code ec;
  if (!IsFolder(file)) return fs::is_regular_file(out / file, ec);
  const fs::path folder = out / file.substr(0, file.size() - 1);
  return !fs::is_symlink(folder, ec) && fs::is_directory(folder, ec);
}

}  // namespace

std::string RunFingerprint(const std::string& run_dir, const std::string& settings) {
  Fnv hash;
  hash.Add(settings);
  hash.Add(fs::absolute(run_dir).lexically_normal().string());
  const fs::path run(run_dir);
  for (const char* name : {"camera.yaml", "classes.yaml", "odometry.csv"})
    AddFile(run / name, run, &hash);
  for (const fs::path& file : FilesOf(run / "frames")) AddFile(file, run, &hash);
  for (const fs::path& file : FilesOf(run))
    if (file.stem() == "video") AddFile(file, run, &hash);
  for (const fs::path& file : FilesOf(run / "ground_truth")) AddFile(file, run, &hash);
  return hash.Hex();
}

RunStatus::RunStatus(std::string out_dir, std::string run_dir, std::string fingerprint,
                     std::vector<RunStage> stages)
    : out_dir_(std::move(out_dir)),
      run_dir_(std::move(run_dir)),
      fingerprint_(std::move(fingerprint)),
      stages_(std::move(stages)),
      states_(stages_.size(), "pending") {}

std::vector<std::string> RunStatus::Reusable(const std::string& out_dir,
                                             const std::string& fingerprint,
                                             const std::vector<RunStage>& stages) {
  std::vector<std::string> reusable;
  try {
    const Json status = Json::parse(ReadTextFile((fs::path(out_dir) / kFileName).string()));
    if (status.at("fingerprint") != fingerprint) return reusable;
    const Json& states = status.at("stages");
    for (const RunStage& stage : stages) {
      const bool done = states.contains(stage.name) &&
                        (states.at(stage.name) == "complete" || states.at(stage.name) == "reused");
      const bool present =
          std::all_of(stage.files.begin(), stage.files.end(),
                      [&](const std::string& file) { return Present(out_dir, file); });
      if (!done || !present) break;
      reusable.push_back(stage.name);
    }
  } catch (const std::exception&) {
    reusable.clear();  // no run.json, or not one oslam wrote: nothing to reuse
  }
  return reusable;
}

void RunStatus::Start(const std::vector<std::string>& keep) {
  for (size_t i = 0; i < stages_.size(); ++i) {
    if (std::find(keep.begin(), keep.end(), stages_[i].name) != keep.end()) continue;
    for (const std::string& file : stages_[i].files) Remove(out_dir_, file);
    for (const std::string& file : stages_[i].stale) Remove(out_dir_, file);
  }
  Write("running", "");
}

void RunStatus::Mark(const std::string& stage, const std::string& state) {
  for (size_t i = 0; i < stages_.size(); ++i)
    if (stages_[i].name == stage) states_[i] = state;
  Write("running", "");
}

void RunStatus::Complete() {
  Write("complete", "");
}

void RunStatus::Fail(const std::string& error) noexcept {
  try {
    for (std::string& state : states_)
      if (state == "running") state = "failed";
    Write("failed", error);
  } catch (...) {
    // The disk may be what failed: the run's error is the one to report.
  }
}

void RunStatus::Write(const std::string& status, const std::string& error) {
  Json json = {{"format", "oslam-run"},
               {"status", status},
               {"run", run_dir_},
               {"fingerprint", fingerprint_},
               {"pid", static_cast<long>(::getpid())}};
  Json stages = Json::object();
  for (size_t i = 0; i < stages_.size(); ++i) stages[stages_[i].name] = states_[i];
  json["stages"] = stages;
  if (!error.empty()) json["error"] = error;
  WriteTextFileAtomically((fs::path(out_dir_) / kFileName).string(),
                          json.dump(1, ' ', false, Json::error_handler_t::replace) + "\n");
}

}  // namespace oslam
