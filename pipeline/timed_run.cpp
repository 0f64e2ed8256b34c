#include "pipeline/timed_run.h"

#include <filesystem>
#include <map>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.h"
#include "core/csv.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "core/text.h"

namespace oslam {
namespace fs = std::filesystem;
namespace {

// The source's ground truth restricted to the kept frames, renumbered 0..K-1.
GroundTruth KeptGroundTruth(const GroundTruth& truth, const FrameSelection& selection,
                            const std::string& source) {
  GroundTruth kept;
  kept.objects = truth.objects;
  std::map<long, long> renumber;
  for (size_t k = 0; k < selection.frames.size(); ++k) {
    const long frame = selection.frames[k];
    if (frame >= static_cast<long>(truth.trajectory.size()))
      throw Error::InFile(source, "ground_truth/trajectory.csv has fewer rows than the frames");
    kept.trajectory.push_back(truth.trajectory[frame]);
    renumber[frame] = static_cast<long>(k);
  }
  for (GroundTruthSighting sighting : truth.sightings) {
    const auto it = renumber.find(sighting.frame);
    if (it == renumber.end()) continue;
    sighting.frame = it->second;
    kept.sightings.push_back(sighting);
  }
  return kept;
}

void WriteFrameTable(const FrameSelection& selection, const std::string& dir) {
  std::ostringstream times, table;
  times << "frame,stamp_s\n";
  table << "frame,source_frame,stamp_s,x_m,y_m,theta_rad\n";
  for (size_t k = 0; k < selection.frames.size(); ++k) {
    times << k << ',' << CsvNumber(selection.times_s[k]) << '\n';
    const Pose2& p = selection.poses[k];
    table << k << ',' << selection.frames[k] << ',' << CsvNumber(selection.times_s[k]) << ','
          << CsvNumber(p.x) << ',' << CsvNumber(p.y) << ',' << CsvNumber(p.theta) << '\n';
  }
  WriteTextFileAtomically((fs::path(dir) / "frame_times.csv").string(), times.str());
  WriteTextFileAtomically((fs::path(dir) / "frames.csv").string(), table.str());
}

}  // namespace

TimedRunResult PrepareTimedRun(const std::string& run_or_video, const std::string& out_run_dir,
                               const FrameSelectionOptions& options, const StageOutput& output) {
  const RunFolderPaths paths = RunFolderPaths::Of(run_or_video);
  const FrameSource frames(run_or_video);
  if (frames.times().empty())
    throw Error::InFile(paths.odometry,
                        "is by time (stamp_s) but the frames have no times: give "
                        "frame_times.csv (frame,stamp_s) or a video with a frame rate");
  const TimedOdometry odometry = ReadTimedOdometry(paths.odometry);
  TimedRunResult result;
  try {
    result.selection = SelectFrames(odometry, frames.times(), options);
  } catch (const Error& e) {
    throw Error::InFile(paths.odometry, e.what());
  }
  const FrameSelection& selection = result.selection;
  result.run_dir = out_run_dir;
  const fs::path dir(out_run_dir);
  if (fs::exists(dir / "frames")) fs::remove_all(dir / "frames");
  fs::create_directories(dir / "frames");

  // Frames in increasing order: one pass of a video's decoder.
  Progress progress("frames", selection.frames.size(), "frames", output.quiet);
  for (size_t k = 0; k < selection.frames.size(); ++k) {
    std::vector<unsigned char> png;
    const cv::Mat image = frames.Read(static_cast<size_t>(selection.frames[k]));
    if (!cv::imencode(".png", image, png, {cv::IMWRITE_PNG_COMPRESSION, 1}))
      throw Error::InFile(frames.Name(static_cast<size_t>(selection.frames[k])),
                          "cannot encode frame " + std::to_string(selection.frames[k]));
    WriteFileAtomically((dir / "frames" / Format("%06zu.png", k)).string(),
                        std::string_view(reinterpret_cast<const char*>(png.data()), png.size()),
                        FileSync::kDeferred);
    progress.Update(k + 1);
  }
  SyncFileSystem((dir / "frames").string());
  progress.Done();

  for (const std::string* file : {&paths.camera, &paths.classes})
    WriteTextFileAtomically((dir / fs::path(*file).filename()).string(), ReadTextFile(*file));
  if (fs::exists(paths.mask))  // the static mask applies to the kept frames as well
    WriteTextFileAtomically((dir / "mask.png").string(), ReadTextFile(paths.mask));
  if (const auto truth = ReadGroundTruth(run_or_video))
    WriteGroundTruth(KeptGroundTruth(*truth, selection, paths.ground_truth), out_run_dir);
  WriteFrameTable(selection, out_run_dir);
  // Last: a run folder with odometry.csv is complete.
  WriteOdometryPoses(selection.poses, (dir / "odometry.csv").string());
  return result;
}

}  // namespace oslam
