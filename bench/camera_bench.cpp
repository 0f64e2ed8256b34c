// Throughput of the camera model and the observation model: the renderer
// back-projects every pixel and the solver predicts every detection many
// times, so both are on hot paths.
#include <benchmark/benchmark.h>

#include "calib/hyperbolic_camera.h"
#include "calib/observation_model.h"

namespace oslam {
namespace {

void BM_ProjectToPixelWithJacobian(benchmark::State& state) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  Eigen::Vector3d point(2.0, 1.0, 0.3);
  Eigen::Vector2d pixel;
  Eigen::Matrix<double, 2, 3> jacobian;
  for (auto _ : state) {
    point.x() += 1e-9;
    benchmark::DoNotOptimize(camera.ProjectToPixel(point, &pixel, &jacobian));
    benchmark::DoNotOptimize(pixel);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ProjectToPixelWithJacobian);

void BM_BackProjectFullFrame(benchmark::State& state) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  Ray ray;
  for (auto _ : state) {
    for (int y = 0; y < camera.image_height(); ++y)
      for (int x = 0; x < camera.image_width(); ++x) {
        camera.BackProjectPixel(Eigen::Vector2d(x, y), &ray);
        benchmark::DoNotOptimize(ray);
      }
  }
  state.SetItemsProcessed(state.iterations() * camera.image_width() * camera.image_height());
}
BENCHMARK(BM_BackProjectFullFrame)->Unit(benchmark::kMillisecond);

void BM_PredictSliceWithJacobians(benchmark::State& state) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  const CylinderGeometry object{Eigen::Vector3d(2, 1, 0), 0.6, 0.6};
  Pose2 pose{0.1, -0.2, 0.3};
  BoundingSlice slice;
  SliceJacobians jacobians;
  for (auto _ : state) {
    pose.x += 1e-9;
    benchmark::DoNotOptimize(PredictSlice(camera, pose, object, &slice, &jacobians));
    benchmark::DoNotOptimize(jacobians);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PredictSliceWithJacobians);

}  // namespace
}  // namespace oslam
