#include "samples/simulator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <future>
#include <optional>
#include <random>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "calib/camera_io.h"
#include "calib/observation_model.h"
#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/csv.h"
#include "core/error.h"
#include "core/image_file.h"
#include "core/odometry_sync.h"
#include "core/run_folder.h"
#include "samples/renderer.h"
#include "samples/robot_path.h"
#include "samples/texture.h"

namespace oslam {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Independent random streams per purpose, so adding a draw to one (say, a new
// exposure effect) does not change the robot's path for the same seed.
std::mt19937_64 StreamFor(std::uint64_t seed, std::uint64_t purpose) {
  std::seed_seq sequence{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                         static_cast<std::uint32_t>(purpose)};
  return std::mt19937_64(sequence);
}

std::string FramePath(const std::string& run_dir, long frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06ld.png", frame);
  return (fs::path(run_dir) / "frames" / name).string();
}

void WriteFrame(const cv::Mat& image, const std::string& path) {
  // Fast compression: frames are large and noisy, level 1 is within a few % of 9.
  WriteImage(path, image, {cv::IMWRITE_PNG_COMPRESSION, 1});
}

// RUN/video.mp4, written under a temporary name and renamed when complete
// (a reader never sees half a video).
class VideoOutput {
 public:
  VideoOutput(const std::string& run_dir, double frame_rate_hz, cv::Size size)
      : path_((fs::path(run_dir) / "video.mp4").string()),
        temp_path_((fs::path(run_dir) / "video.partial.mp4").string()) {
    for (const char* codec : {"avc1", "mp4v"}) {
      const int fourcc = cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]);
      if (writer_.open(temp_path_, cv::CAP_FFMPEG, fourcc, frame_rate_hz, size)) return;
    }
    throw Error::InFile(path_, "OpenCV cannot write an mp4 video (no H.264 or MPEG-4 encoder)");
  }
  void Write(const cv::Mat& frame) { writer_.write(frame); }
  void Finish() {
    writer_.release();
    std::error_code ec;
    fs::rename(temp_path_, path_, ec);
    if (ec) throw Error::InFile(path_, "cannot rename the finished video: " + ec.message());
  }

 private:
  std::string path_, temp_path_;
  cv::VideoWriter writer_;
};

// odometry.csv by time: rows every 1 / rate s of the video's clock from the
// first frame to the last, stamped on the odometry's clock (+ offset).
void WriteTimedOdometry(const std::vector<Pose2>& per_frame, const SimulationOptions& options,
                        const std::string& path) {
  TimedOdometry frames;
  for (size_t i = 0; i < per_frame.size(); ++i) {
    frames.stamps_s.push_back(static_cast<double>(i) / options.video_frame_rate_hz);
    frames.poses.push_back(per_frame[i]);
  }
  const double last = frames.stamps_s.back();
  std::ostringstream out;
  out << "stamp_s,x_m,y_m,theta_rad\n";
  for (long k = 0;; ++k) {
    const double t = std::min(last, static_cast<double>(k) / options.odometry_rate_hz);
    const Pose2 pose = per_frame.size() > 1 ? InterpolateOdometry(frames, t) : per_frame[0];
    out << CsvNumber(t + options.odometry_offset_s) << ',' << CsvNumber(pose.x) << ','
        << CsvNumber(pose.y) << ',' << CsvNumber(pose.theta) << '\n';
    if (t >= last) break;
  }
  WriteTextFileAtomically(path, out.str());
}

// One row of ground_truth/visible_slices.csv: the pixel-measured slice of a
// sighting's visible part.
struct VisibleSliceRow {
  long frame = 0;
  int object_id = 0;
  long visible_px = 0, footprint_px = 0;
  BoundingSlice slice;
};

// Sightings of one frame: every object with at least one visible pixel whose
// cylinder-model slice exists (base and top imaged by the mirror).
void AddSightings(const Scene& scene, const Renderer& renderer, const Pose2& pose, long frame,
                  const FrameRender& render, const std::vector<GroundTruthObject>& objects,
                  std::vector<GroundTruthSighting>* sightings,
                  std::vector<VisibleSliceRow>* visible_rows) {
  const std::vector<BoundingSlice> measured = renderer.VisibleSlices(render);
  for (size_t j = 0; j < objects.size(); ++j) {
    const long visible = render.visible_pixels[j];
    if (visible == 0) continue;
    const GroundTruthObject& object = objects[j];
    BoundingSlice slice;
    if (!PredictSlice(*scene.camera, pose, {object.base_world, object.diameter_m, object.height_m},
                      &slice)) {
      continue;
    }
    const long footprint = std::max(visible, renderer.FootprintPixels(pose, static_cast<int>(j)));
    sightings->push_back({frame, object.id, slice.u_r_px, slice.u_phi_rad, slice.s_r_px,
                          slice.s_phi_rad, static_cast<double>(visible) / footprint});
    visible_rows->push_back({frame, object.id, visible, footprint, measured[j]});
  }
}

void WriteVisibleSlices(const std::vector<VisibleSliceRow>& rows, const std::string& run_dir) {
  std::ostringstream out;
  out << "frame,object_id,visible_px,footprint_px,u_r_px,u_phi_rad,s_r_px,s_phi_rad\n";
  for (const VisibleSliceRow& row : rows) {
    out << row.frame << ',' << row.object_id << ',' << row.visible_px << ',' << row.footprint_px
        << ',' << CsvNumber(row.slice.u_r_px) << ',' << CsvNumber(row.slice.u_phi_rad) << ','
        << CsvNumber(row.slice.s_r_px) << ',' << CsvNumber(row.slice.s_phi_rad) << '\n';
  }
  WriteTextFileAtomically((fs::path(run_dir) / "ground_truth" / "visible_slices.csv").string(),
                          out.str());
}

double PathLength(const std::vector<Pose2>& poses) {
  double length = 0.0;
  for (size_t i = 1; i < poses.size(); ++i)
    length += std::hypot(poses[i].x - poses[i - 1].x, poses[i].y - poses[i - 1].y);
  return length;
}

}  // namespace

SimulationSummary Simulate(const Scene& scene, const std::string& run_dir,
                           const SimulationOptions& options) {
  const Clock::time_point start = Clock::now();
  auto report = [&](const std::string& line, bool final) {
    if (options.progress) options.progress(line, final);
  };
  SimulationSummary summary;
  const long max_frames = options.max_frames > 0 ? options.max_frames : scene.max_frames;

  std::mt19937_64 path_rng = StreamFor(options.seed, 1);
  const DrivenPath path = FilmedAtFramesPerStep(
      DrivePath(scene.path_spec, scene.odometry, max_frames, path_rng), options.frames_per_step);
  summary.frames = static_cast<long>(path.true_poses.size());
  summary.path_length_m = PathLength(path.true_poses);
  const Pose2& last_truth = path.true_poses.back();
  const Pose2& last_odometry = path.odometry_poses.back();
  summary.odometry_final_error_m =
      std::hypot(last_truth.x - last_odometry.x, last_truth.y - last_odometry.y);
  char line[256];
  std::snprintf(line, sizeof(line),
                "path: %ld frames, %.1f m driven, odometry off by %.2f m at the end",
                summary.frames, summary.path_length_m, summary.odometry_final_error_m);
  report(line, true);

  const bool video = options.video_frame_rate_hz > 0;
  fs::create_directories(video ? fs::path(run_dir) : fs::path(run_dir) / "frames");
  SaveCamera(*scene.camera, RunFolderPaths::Of(run_dir).camera);
  WriteClasses(scene.classes, RunFolderPaths::Of(run_dir).classes);

  GroundTruth truth;
  truth.trajectory = path.true_poses;
  for (size_t j = 0; j < scene.objects.size(); ++j)
    truth.objects.push_back(GroundTruthOf(scene.objects[j], static_cast<int>(j)));

  const Renderer renderer(scene);
  std::mt19937_64 exposure_rng = StreamFor(options.seed, 2);
  std::normal_distribution<double> normal(0.0, 1.0);
  FrameRender render;
  std::vector<VisibleSliceRow> visible_rows;
  // PNG encoding of frame i overlaps the rendering of frame i + 1; the bytes
  // do not depend on the timing.
  std::future<void> pending_write;
  std::optional<VideoOutput> video_output;
  std::mt19937_64 effects_rng = StreamFor(options.seed, 3);
  std::optional<CameraEffects> effects;
  if (options.realism.enabled) {
    effects.emplace(*scene.camera, options.realism, effects_rng);
    fs::create_directories(fs::path(run_dir) / "ground_truth");
    WriteImage((fs::path(run_dir) / "ground_truth" / "mask.png").string(), effects->rig_mask());
  }
  if (video)
    video_output.emplace(run_dir, options.video_frame_rate_hz,
                         cv::Size(scene.camera->image_width(), scene.camera->image_height()));
  for (long frame = 0; frame < summary.frames; ++frame) {
    const Clock::time_point frame_start = Clock::now();
    FrameConditions conditions;
    conditions.gain = std::exp(scene.sensor.exposure_std * normal(exposure_rng));
    conditions.noise_key =
        MixBits(options.seed * 0x100000001b3ULL + static_cast<std::uint64_t>(frame));
    renderer.Render(path.true_poses[frame], conditions, &render);
    AddSightings(scene, renderer, path.true_poses[frame], frame, render, truth.objects,
                 &truth.sightings, &visible_rows);
    if (effects)
      effects->Apply(
          &render.image,
          frame > 0 ? WrapAngle(path.true_poses[frame].theta - path.true_poses[frame - 1].theta)
                    : 0.0,
          scene.sensor.noise_std, effects_rng);
    summary.render_seconds += SecondsSince(frame_start);
    if (pending_write.valid()) pending_write.get();  // rethrows a failed write
    if (video_output)
      video_output->Write(render.image);
    else
      pending_write = std::async(std::launch::async, WriteFrame, render.image.clone(),
                                 FramePath(run_dir, frame));
    if ((frame + 1) % 10 == 0 || frame + 1 == summary.frames) {
      std::snprintf(line, sizeof(line), "render: frame %ld/%ld (%.1f frames/s rendering)",
                    frame + 1, summary.frames,
                    (frame + 1) / std::max(1e-9, summary.render_seconds));
      report(line, frame + 1 == summary.frames);
    }
  }
  if (pending_write.valid()) pending_write.get();
  if (video_output) video_output->Finish();
  summary.sightings = static_cast<long>(truth.sightings.size());

  // Odometry and ground truth last: a run folder with odometry.csv is complete.
  WriteVisibleSlices(visible_rows, run_dir);
  WriteGroundTruth(truth, run_dir);
  if (options.odometry_rate_hz > 0 && video)
    WriteTimedOdometry(path.odometry_poses, options, RunFolderPaths::Of(run_dir).odometry);
  else
    WriteOdometryPoses(path.odometry_poses, RunFolderPaths::Of(run_dir).odometry);
  summary.total_seconds = SecondsSince(start);
  std::snprintf(line, sizeof(line), "ground truth: %zu objects, %ld sightings; wrote %s in %.1f s",
                truth.objects.size(), summary.sightings, run_dir.c_str(), summary.total_seconds);
  report(line, true);
  return summary;
}

}  // namespace oslam
