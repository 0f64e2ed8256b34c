// The status of an `oslam run` output folder, OUT/run.json (docs/formats.md,
// "run.json"): written atomically as the run starts, as each stage ends and
// as the run ends, so that a folder whose status is not "complete" is known
// to hold an unfinished run. "running" while the run goes on, or after it was
// killed (its pid is then gone); "failed", with the error, after a failure.
// It also lets `oslam run --resume` reuse the stages a run of the same
// settings on the same inputs completed.
#pragma once

#include <string>
#include <vector>

namespace oslam {

// One stage of a run and the files it writes, relative to the output folder
// (a name ending in '/' is a folder of NNNNNN.jpg or .png images, e.g.
// "overlays/").
struct RunStage {
  std::string name;
  std::vector<std::string> files;
  // What an earlier run with other settings may have left for this stage
  // and this run will not write (overlays/ when overlays are off): removed
  // with the stage's files so the folder shows only this run's results.
  std::vector<std::string> stale = {};
};

// A fingerprint of a run's inputs (the names, sizes and modification times
// of camera.yaml, classes.yaml, odometry.csv, the frames or video, and
// ground_truth/) and of `settings` (the configuration's text): two runs with
// the same fingerprint compute the same thing.
std::string RunFingerprint(const std::string& run_dir, const std::string& settings);

class RunStatus {
 public:
  static constexpr const char* kFileName = "run.json";

  RunStatus(std::string out_dir, std::string run_dir, std::string fingerprint,
            std::vector<RunStage> stages);

  // The leading stages that the last run into `out_dir` completed (or
  // reused) with this fingerprint, whose files are all still there; empty
  // without a readable run.json of the same fingerprint.
  static std::vector<std::string> Reusable(const std::string& out_dir,
                                           const std::string& fingerprint,
                                           const std::vector<RunStage>& stages);

  // Removes the files of every stage not in `keep` (a re-run must not leave
  // an older run's results beside its own), then writes run.json: running.
  // Never follows a symlink out of the folder. Throws oslam::Error naming
  // the file on failure.
  void Start(const std::vector<std::string>& keep);
  // The stage's state in run.json: "running", "complete" or "reused".
  void Mark(const std::string& stage, const std::string& state);
  void Complete();
  // Records the error; best effort (the run is failing already), never throws.
  void Fail(const std::string& error) noexcept;

 private:
  void Write(const std::string& status, const std::string& error);

  std::string out_dir_, run_dir_, fingerprint_;
  std::vector<RunStage> stages_;
  std::vector<std::string> states_;  // per stage: pending, running, complete, reused
};

}  // namespace oslam
