// Simulator speed: frames/s of the ray-casting renderer at 640 x 480 (LPA
// camera, lab scene), one thread. items_per_second is frames/s.
#include <benchmark/benchmark.h>

#include <string>

#include "samples/renderer.h"
#include "samples/robot_path.h"
#include "samples/scene.h"

namespace oslam {
namespace {

const Scene& LabScene() {
  static const Scene scene = LoadScene(std::string(OSLAM_SOURCE_DIR) + "/samples/scenes/lab.yaml");
  return scene;
}

// The lab path's true poses, so the benchmark sees the views a run renders.
std::vector<Pose2> LabPoses() {
  std::mt19937_64 rng(1);
  return DrivePath(LabScene().path_spec, LabScene().odometry, 150, rng).true_poses;
}

void BM_RenderLabFrame(benchmark::State& state) {
  const Renderer renderer(LabScene());
  const std::vector<Pose2> poses = LabPoses();
  FrameRender render;
  size_t frame = 0;
  for (auto _ : state) {
    renderer.Render(poses[frame % poses.size()], {1.0, frame}, &render);
    benchmark::DoNotOptimize(render.image.data);
    ++frame;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
  state.counters["pixels"] = static_cast<double>(renderer.num_annulus_pixels());
}
BENCHMARK(BM_RenderLabFrame)->Unit(benchmark::kMillisecond);

// Rendering plus the ground truth of every visible object (footprints).
void BM_RenderLabFrameWithGroundTruth(benchmark::State& state) {
  const Renderer renderer(LabScene());
  const std::vector<Pose2> poses = LabPoses();
  FrameRender render;
  size_t frame = 0;
  for (auto _ : state) {
    const Pose2& pose = poses[frame % poses.size()];
    renderer.Render(pose, {1.0, frame}, &render);
    long total = 0;
    for (size_t j = 0; j < render.visible_pixels.size(); ++j)
      if (render.visible_pixels[j] > 0)
        total += renderer.FootprintPixels(pose, static_cast<int>(j));
    benchmark::DoNotOptimize(total);
    ++frame;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_RenderLabFrameWithGroundTruth)->Unit(benchmark::kMillisecond);

// The same frames testing every primitive for every pixel: what the bearing
// bins save.
void BM_RenderLabFrameBruteForce(benchmark::State& state) {
  RendererOptions options;
  options.brute_force = true;
  const Renderer renderer(LabScene(), options);
  const std::vector<Pose2> poses = LabPoses();
  FrameRender render;
  size_t frame = 0;
  for (auto _ : state) {
    renderer.Render(poses[frame % poses.size()], {1.0, frame}, &render);
    benchmark::DoNotOptimize(render.image.data);
    ++frame;
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()));
}
BENCHMARK(BM_RenderLabFrameBruteForce)->Unit(benchmark::kMillisecond);

void BM_RendererSetup(benchmark::State& state) {
  for (auto _ : state) {
    const Renderer renderer(LabScene());
    benchmark::DoNotOptimize(renderer.num_annulus_pixels());
  }
}
BENCHMARK(BM_RendererSetup)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace oslam
