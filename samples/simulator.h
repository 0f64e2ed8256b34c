// The simulator: drives the robot through a scene, renders every frame and
// writes a complete run folder (frames/, odometry.csv, camera.yaml,
// classes.yaml, ground_truth/). Same scene and seed, same bytes.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "samples/camera_effects.h"
#include "samples/scene.h"

namespace oslam {

struct SimulationOptions {
  std::uint64_t seed = 1;
  long max_frames = -1;  // -1: the scene's frames (or the whole path)
  // > 0: the frames go into one video file RUN/video.mp4 at this frame rate
  // (H.264 when OpenCV's FFmpeg has an encoder for it, else MPEG-4 part 2)
  // instead of PNGs in RUN/frames/.
  double video_frame_rate_hz = 0.0;
  // > 0 (with a video): odometry.csv by time (docs/formats.md) with rows at
  // this rate on a clock `odometry_offset_s` ahead of the video's (frame i
  // at i / video_frame_rate_hz), from the first to the last frame: the
  // per-frame odometry poses interpolated in SE(2) at the rows' times.
  double odometry_rate_hz = 0.0;
  double odometry_offset_s = 0.0;
  // Frames per command of the path (FilmedAtFramesPerStep): 1 = one frame per
  // stop (the thesis' stop-and-go images); more = a video of the robot moving
  // between the stops, from which a run keeps frames by distance and turn.
  // max_frames counts stops.
  int frames_per_step = 1;
  // realism.enabled: the frames as a real rig records them (the robot's body
  // and mirror rods, motion blur, auto-exposure, vignetting, JPEG;
  // samples/camera_effects.h), with the rig's true mask in
  // ground_truth/mask.png. Off by default: the ideal renders.
  RealismOptions realism;
  // Called with one line per stage and, during rendering, with progress
  // updates (final = true for the stage's last line).
  std::function<void(const std::string& line, bool final)> progress;
};

struct SimulationSummary {
  long frames = 0;
  double path_length_m = 0.0;
  double odometry_final_error_m = 0.0;  // |odometry - truth| at the last frame
  long sightings = 0;
  double render_seconds = 0.0;  // ray casting and ground truth, without PNG writing
  double total_seconds = 0.0;
};

// Writes into run_dir (created if needed); each file is written atomically.
SimulationSummary Simulate(const Scene& scene, const std::string& run_dir,
                           const SimulationOptions& options);

}  // namespace oslam
