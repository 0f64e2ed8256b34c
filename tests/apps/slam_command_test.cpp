// oslam slam end to end on a tiny synthetic run folder (camera, classes,
// noisy odometry, detections predicted by the observation model with pixel
// noise, ground truth): the O-Map it writes is read back with ReadOMap and
// checked (objects found with pi > 0.5 near the true ones, no spurious
// objects, classes, trajectory better than odometry), and so is the O-SLAM
// section of the JSON (convergence report) and the nearest-neighbour baseline.
#include <cmath>
#include <fstream>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "calib/camera_io.h"
#include "calib/hyperbolic_camera.h"
#include "core/error.h"
#include "detect/blob_detector.h"
#include "omap/omap_json.h"
#include "slam/synthetic_scene.h"
#include "test_util.h"

namespace oslam {
namespace {

struct TinyRun {
  testing::TempDir dir;
  testing::SyntheticScene scene;
  std::vector<Pose2> odometry;
};

// 90 frames along one rectangle side and corner, 4 objects (2 classes).
void MakeTinyRun(TinyRun* run) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  testing::SyntheticSceneOptions options;
  options.num_poses = 90;
  options.num_objects = 4;
  options.loop_length_m = 4.0;
  options.loop_width_m = 3.0;
  options.pixel_std_px = 0.5;
  options.odometry_noise = true;
  options.seed = 3;
  run->scene = testing::MakeSyntheticScene(camera, options);
  const GeometricSlamProblem& p = run->scene.problem;
  SaveCamera(camera, run->dir.Path("camera.yaml"));
  std::vector<ObjectClass> classes;
  for (const ClassPrior& prior : p.classes) {
    ObjectClass c;
    c.name = prior.name;
    c.diameter_mean_m = prior.size_mean_m.x();
    c.height_mean_m = prior.size_mean_m.y();
    c.diameter_std_m = prior.size_std_m.x();
    c.height_std_m = prior.size_std_m.y();
    classes.push_back(c);
  }
  WriteClasses(classes, run->dir.Path("classes.yaml"));
  run->odometry = ComposeOdometry(p.first_pose, p.increments);
  WriteOdometryPoses(run->odometry, run->dir.Path("odometry.csv"));
  std::vector<Detection> detections;
  for (const auto& o : p.observations) {
    Detection d;
    d.frame = o.frame;
    d.class_index = p.object_class.at(o.object_id);
    d.class_name = classes[d.class_index].name;
    d.slice = o.slice;
    d.area_px = 100;
    d.score = 1.0;
    detections.push_back(d);
  }
  WriteDetections(detections, run->dir.Path("detections.csv"));
  GroundTruth truth;
  truth.trajectory = run->scene.true_trajectory;
  for (size_t j = 0; j < run->scene.true_objects.size(); ++j) {
    GroundTruthObject o;
    o.id = static_cast<int>(j);
    o.class_name = classes[p.object_class.at(static_cast<int>(j))].name;
    o.shape = "cylinder";
    o.base_world = run->scene.true_objects[j].base_world;
    o.diameter_m = run->scene.true_objects[j].diameter_m;
    o.height_m = run->scene.true_objects[j].height_m;
    truth.objects.push_back(o);
  }
  WriteGroundTruth(truth, run->dir.Path());
}

double TrajectoryRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i)
    sum += std::pow(a[i].x - b[i].x, 2) + std::pow(a[i].y - b[i].y, 2);
  return std::sqrt(sum / a.size());
}

TEST(SlamCommand, OSlamMapReadsBackWithObjectsAndTrajectory) {
  TinyRun run;
  MakeTinyRun(&run);
  const std::string out = run.dir.Path("omap.json");
  ASSERT_EQ(RunSlamCommand({run.dir.Path(), "-o", out, "--hill-climb", "30", "--samples", "120",
                            "--burn-in", "20", "--quiet"}),
            0);
  const OMap map = ReadOMap(out);
  const auto& truth = run.scene.true_objects;
  ASSERT_EQ(map.trajectory.size(), run.scene.true_trajectory.size());
  const double odometry_error = TrajectoryRmse(run.odometry, run.scene.true_trajectory);
  const double error = TrajectoryRmse(map.trajectory, run.scene.true_trajectory);
  EXPECT_LT(error, odometry_error) << "odometry " << odometry_error;
  int above = 0;
  std::vector<int> found(truth.size(), 0);
  for (const OMapObject& o : map.objects) {
    EXPECT_GE(o.existence_probability, 0.0);
    EXPECT_LE(o.existence_probability, 1.0);
    if (o.existence_probability <= 0.5) continue;
    ++above;
    size_t nearest = 0;
    for (size_t j = 1; j < truth.size(); ++j)
      if ((truth[j].base_world - o.base_world).norm() <
          (truth[nearest].base_world - o.base_world).norm())
        nearest = j;
    // Loose: E = 30 px (thesis) and some objects are seen from few places.
    EXPECT_LT((truth[nearest].base_world - o.base_world).head<2>().norm(), 0.6)
        << o.class_name << " " << o.base_world.transpose();
    EXPECT_EQ(o.class_name,
              run.scene.problem.classes[run.scene.problem.object_class.at(int(nearest))].name);
    ASSERT_FALSE(o.class_histogram.empty());
    EXPECT_EQ(o.class_histogram.front().first, o.class_name);
    ++found[nearest];
  }
  // Every object the robot saw is found once; none twice, nothing spurious.
  std::set<int> seen;
  for (const auto& obs : run.scene.problem.observations) seen.insert(obs.object_id);
  for (size_t j = 0; j < truth.size(); ++j) EXPECT_EQ(found[j], seen.count(int(j)) ? 1 : 0) << j;
  EXPECT_EQ(above, static_cast<int>(seen.size()));

  // The O-SLAM fields: convergence report and identities.
  std::ifstream in(out);
  const nlohmann::json json = nlohmann::json::parse(in);
  EXPECT_EQ(json["source"]["association"], "o-slam (MC3)");
  const auto& sampler = json.at("sampler");
  EXPECT_EQ(sampler["cold_chain_log_target"].size(), 120u);
  EXPECT_TRUE(sampler["effective_sample_size"].is_number());
  // --hill-climb 30 is the minimum; patience may climb further.
  EXPECT_GE(sampler["hill_climb_log_target"].size(), 30u);
  EXPECT_EQ(sampler["hill_climb_log_target"].size(), sampler["hill_climb_steps"].get<size_t>());
  // Run times are left out: the same input and seed give the same file.
  EXPECT_FALSE(json.contains("timing"));
  EXPECT_FALSE(sampler.contains("cold_chain_proposals_per_second"));
  for (const char* move : {"merge", "split", "switch"}) {
    EXPECT_TRUE(sampler["sampling_moves"][move].contains("acceptance_rate")) << move;
    EXPECT_FALSE(sampler["sampling_moves"][move].contains("time_per_proposal_s")) << move;
  }
  for (const auto& o : json["objects"]) {
    EXPECT_FALSE(o["identities"].empty());
    // Detections, not tracks: every track holds at least --min-track-length (3).
    EXPECT_GE(o["num_detections"].get<size_t>(), 3 * o["tracks"].size());
  }
}

// Chains on threads (with delayed acceptance; running ahead of the swap
// decisions, and sent back when a swap is accepted) give exactly what
// stepping them one after another gives. A small temperature step makes
// swaps frequent.
TEST(SlamCommand, SameSeedSameOMapWithAndWithoutThreads) {
  TinyRun run;
  MakeTinyRun(&run);
  for (const std::vector<std::string>& schedule :
       {std::vector<std::string>{"--swap-every", "3"},
        std::vector<std::string>{"--swap-every", "1", "--delta-t", "0.3"}}) {
    std::vector<nlohmann::json> results;
    for (const char* mode : {"--threads", "--sequential"}) {
      const std::string out = run.dir.Path(std::string("omap") + mode + ".json");
      std::vector<std::string> args = {run.dir.Path(), "-o",        out,  "--hill-climb",
                                       "20",           "--samples", "80", "--burn-in",
                                       "10",           "--seed",    "5",  "--quiet"};
      args.insert(args.end(), schedule.begin(), schedule.end());
      if (std::string(mode) == "--sequential") args.push_back(mode);
      ASSERT_EQ(RunSlamCommand(args), 0);
      std::ifstream in(out);
      results.push_back(nlohmann::json::parse(in));
    }
    SCOPED_TRACE(schedule[1]);
    // The whole file: run times are not in it.
    EXPECT_EQ(results[0], results[1]);
    EXPECT_EQ(results[0]["sampler"], results[1]["sampler"]);
    EXPECT_EQ(results[0]["objects"], results[1]["objects"]);
    EXPECT_EQ(results[0]["trajectory"], results[1]["trajectory"]);
    EXPECT_EQ(results[0]["sampler"]["cold_chain_log_target"].size(), 80u);
    EXPECT_GT(results[0]["sampler"]["swaps_accepted"].get<int>(), 0);
  }
}

TEST(SlamCommand, NearestNeighbourBaselineAndUsageErrors) {
  TinyRun run;
  MakeTinyRun(&run);
  const std::string out = run.dir.Path("nn.json");
  ASSERT_EQ(RunSlamCommand({run.dir.Path(), "-o", out, "--baseline", "nn", "--quiet"}), 0);
  const OMap map = ReadOMap(out);
  EXPECT_EQ(map.trajectory.size(), run.scene.true_trajectory.size());
  EXPECT_FALSE(map.objects.empty());
  EXPECT_THROW(RunSlamCommand({run.dir.Path()}), UsageError);  // no -o
  EXPECT_THROW(RunSlamCommand({run.dir.Path(), "-o", out, "--baseline", "x"}), UsageError);
  EXPECT_THROW(RunSlamCommand({run.dir.Path("missing"), "-o", out, "--quiet"}), Error);
}

}  // namespace
}  // namespace oslam
