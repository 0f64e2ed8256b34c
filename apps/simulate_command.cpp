// oslam simulate: render a scene into a run folder with ground truth.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "core/error.h"
#include "samples/scene.h"
#include "samples/simulator.h"

namespace oslam {

namespace {

namespace fs = std::filesystem;

// A folder that already holds frames would mix two runs: refuse it.
void CheckOutputFolder(const std::string& run_dir) {
  if (fs::exists(run_dir) && !fs::is_directory(run_dir))
    throw Error::InFile(run_dir, "exists and is not a folder");
  const fs::path frames = fs::path(run_dir) / "frames";
  if (fs::is_directory(frames) && !fs::is_empty(frames))
    throw Error::InFile(run_dir, "already holds a run (frames/ is not empty); choose a new folder");
  if (fs::exists(fs::path(run_dir) / "video.mp4"))
    throw Error::InFile(run_dir, "already holds a run (video.mp4); choose a new folder");
}

// Progress on stderr: updates overwrite one line on a terminal, and only the
// final line of each stage is printed otherwise (logs stay short).
void PrintProgress(const std::string& line, bool final) {
  static const bool terminal = ::isatty(STDERR_FILENO) != 0;
  if (terminal) {
    std::fprintf(stderr, "\r\033[K%s%s", line.c_str(), final ? "\n" : "");
  } else if (final) {
    std::fprintf(stderr, "%s\n", line.c_str());
  }
  std::fflush(stderr);
}

}  // namespace

int RunSimulateCommand(const std::vector<std::string>& args) {
  Arguments arguments("oslam simulate SCENE.yaml -o RUN_DIR [options]",
                      "Renders a simulated omnidirectional robot run (frames, odometry, camera,\n"
                      "classes and ground truth) from a scene file; see docs/simulator.md.");
  arguments.AddPositional("scene", "scene file (e.g. samples/scenes/lab.yaml)");
  arguments.AddOption("output", "-o", "RUN_DIR", "run folder to write (new or empty)");
  arguments.AddOption("seed", "", "N", "random seed (default: the scene's seed)");
  arguments.AddOption("frames", "", "N",
                      "drive at most N steps, one frame each (default: the whole path)");
  arguments.AddOption("frames-per-step", "", "N",
                      "film each step with N frames, the robot moving between its stops\n"
                      "(a video at the robot's own speed; runs keep frames by distance)",
                      "1");
  arguments.AddOption("video", "", "FPS",
                      "write the frames as one video, RUN_DIR/video.mp4 at FPS frames/s,\n"
                      "instead of PNGs in RUN_DIR/frames/");
  arguments.AddOption("odometry-rate", "", "HZ",
                      "with --video: odometry.csv by time, rows at HZ from the first frame to\n"
                      "the last (docs/formats.md, Odometry by time)");
  arguments.AddOption("odometry-offset", "", "S",
                      "with --odometry-rate: the odometry clock is S seconds ahead of the video's",
                      "0");
  arguments.AddFlag("realistic",
                    "frames as a real rig records them: the robot's body and mirror rods in the\n"
                    "image, motion blur, auto-exposure, vignetting, JPEG compression (seeded;\n"
                    "the rig's true mask in RUN_DIR/ground_truth/mask.png)");
  arguments.AddOption("jpeg-quality", "", "Q",
                      "with --realistic: JPEG quality of every frame, 1-100 (0 = none)", "60");
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("output")) throw UsageError("missing -o RUN_DIR");
  const std::string run_dir = arguments.Get("output");

  const Scene scene = LoadScene(arguments.Get("scene"));
  SimulationOptions options;
  options.seed = scene.seed;
  if (arguments.Has("seed")) {
    const long seed = arguments.GetInt("seed");
    if (seed < 0) throw UsageError("--seed must not be negative");
    options.seed = static_cast<std::uint64_t>(seed);
  }
  if (arguments.Has("frames")) {
    options.max_frames = arguments.GetInt("frames");
    if (options.max_frames < 1) throw UsageError("--frames must be at least 1");
  }
  if (arguments.Has("frames-per-step")) {
    const long per_step = arguments.GetInt("frames-per-step");
    if (per_step < 1 || per_step > 100) throw UsageError("--frames-per-step expects 1..100");
    options.frames_per_step = static_cast<int>(per_step);
  }
  if (arguments.Has("video")) {
    options.video_frame_rate_hz = arguments.GetDouble("video");
    if (!(options.video_frame_rate_hz > 0) || options.video_frame_rate_hz > 1000)
      throw UsageError("--video expects a frame rate in frames/s (e.g. 30)");
  }
  if (arguments.Has("odometry-rate")) {
    if (!arguments.Has("video")) throw UsageError("--odometry-rate needs --video FPS");
    options.odometry_rate_hz = arguments.GetDouble("odometry-rate");
    if (!(options.odometry_rate_hz > 0) || options.odometry_rate_hz > 10000)
      throw UsageError("--odometry-rate expects a rate in Hz (e.g. 20)");
    options.odometry_offset_s = arguments.GetDouble("odometry-offset");
    if (!std::isfinite(options.odometry_offset_s))
      throw UsageError("--odometry-offset expects seconds");
  } else if (arguments.Has("odometry-offset")) {
    throw UsageError("--odometry-offset needs --odometry-rate HZ");
  }
  options.realism.enabled = arguments.Flag("realistic");
  if (arguments.Has("jpeg-quality")) {
    if (!options.realism.enabled) throw UsageError("--jpeg-quality needs --realistic");
    const long quality = arguments.GetInt("jpeg-quality");
    if (quality < 0 || quality > 100) throw UsageError("--jpeg-quality expects 0..100");
    options.realism.jpeg_quality = static_cast<int>(quality);
  }
  CheckOutputFolder(run_dir);
  const bool quiet = arguments.Flag("quiet");
  if (!quiet) {
    options.progress = PrintProgress;
    std::fprintf(stderr,
                 "scene %s: %zu objects, %zu walls, %zu classes, camera %s %dx%d, seed %llu\n",
                 scene.name.c_str(), scene.objects.size(), scene.walls.size(), scene.classes.size(),
                 scene.camera_description.c_str(), scene.camera->image_width(),
                 scene.camera->image_height(), static_cast<unsigned long long>(options.seed));
  }
  Simulate(scene, run_dir, options);
  return 0;
}

}  // namespace oslam
