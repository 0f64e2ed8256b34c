// A geometric SLAM result as an O-Map: objects named by class, the
// trajectory, the source, and the solver and evidence reports as the file
// has them.
#include "slam/slam_omap.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace oslam {
namespace {

GeometricSlamResult Result() {
  GeometricSlamResult result;
  result.trajectory = {{0, 0, 0}, {0.5, 0.1, 0.2}};
  MappedObject box;
  box.id = 4;
  box.class_index = 1;
  box.geometry.base_world = {1, 2, 0.1};
  box.geometry.diameter_m = 0.6;
  box.geometry.height_m = 0.5;
  box.covariance = Eigen::Matrix<double, 5, 5>::Identity() * 0.01;
  box.num_observations = 17;
  MappedObject unknown = box;  // a class index outside the names
  unknown.id = 9;
  unknown.class_index = 5;
  result.objects = {box, unknown};
  result.summary.termination = TerminationType::kConverged;
  result.summary.message = "function tolerance reached";
  result.summary.iterations = 12;
  result.summary.successful_steps = 10;
  result.summary.initial_cost = std::numeric_limits<double>::quiet_NaN();
  result.summary.final_cost = 3.5;
  result.summary.num_factors = 20;
  result.summary.num_residuals = 44;
  result.summary.num_parameters = 16;
  result.evidence.valid = false;
  result.evidence.log_evidence = -7;  // not written: the evidence is not valid
  result.evidence.num_rows = 44;
  return result;
}

TEST(SlamOMap, GeometricResultBecomesAnOMap) {
  const OMapSource source{"runs/lab", "known (ground truth)", std::nullopt, 30.0, 3};
  const OMap map = ToOMap(Result(), {"ball", "green box"}, source);
  ASSERT_EQ(map.objects.size(), 2u);
  const OMapObject& box = map.objects[0];
  EXPECT_EQ(box.id, 4);
  EXPECT_EQ(box.class_name, "green box");
  EXPECT_EQ(box.base_world, Eigen::Vector3d(1, 2, 0.1));
  EXPECT_EQ(box.diameter_m, 0.6);
  EXPECT_EQ(box.height_m, 0.5);
  EXPECT_EQ(box.existence_probability, 1.0);
  EXPECT_EQ(box.covariance(2, 2), 0.01);
  EXPECT_EQ(box.num_detections, 17);
  EXPECT_TRUE(box.class_histogram.empty());
  EXPECT_FALSE(box.identity);
  EXPECT_EQ(map.objects[1].class_name, "");
  ASSERT_EQ(map.trajectory.size(), 2u);
  EXPECT_EQ(map.trajectory[1].theta, 0.2);
  ASSERT_TRUE(map.source);
  EXPECT_EQ(map.source->pixel_noise_px, std::optional<double>(30.0));
  EXPECT_EQ(map.source->seed, 3u);

  ASSERT_EQ(map.reports.size(), 2u);
  ASSERT_EQ(map.reports[0].name, "solver");
  const nlohmann::json solver = nlohmann::json::parse(map.reports[0].json);
  EXPECT_EQ(solver["termination"], "converged");
  EXPECT_EQ(solver["message"], "function tolerance reached");
  EXPECT_EQ(solver["iterations"], 12);
  EXPECT_EQ(solver["successful_steps"], 10);
  EXPECT_TRUE(solver["initial_cost"].is_null());
  EXPECT_EQ(solver["final_cost"], 3.5);
  EXPECT_EQ(solver["num_residuals"], 44);
  EXPECT_FALSE(solver.contains("total_time_s"));  // in the timing
  ASSERT_EQ(map.timing.size(), 1u);
  EXPECT_EQ(map.timing[0].name, "solver");
  EXPECT_TRUE(nlohmann::json::parse(map.timing[0].json).contains("total_time_s"));
  EXPECT_FALSE(solver.contains("keyframe_start"));
  ASSERT_EQ(map.reports[1].name, "evidence");
  const nlohmann::json evidence = nlohmann::json::parse(map.reports[1].json);
  EXPECT_EQ(evidence["valid"], false);
  EXPECT_TRUE(evidence["log_evidence"].is_null());
  EXPECT_EQ(evidence["num_rows"], 44);
  for (const char* key :
       {"squared_residual", "log_det_information", "log_det_noise", "normaliser", "num_parameters"})
    EXPECT_TRUE(evidence.contains(key)) << key;
}

TEST(SlamOMap, KeyframeStartIsPartOfTheSolverReport) {
  GeometricSlamResult result = Result();
  result.keyframe_start.used = true;
  result.keyframe_start.num_keyframes = 30;
  result.keyframe_start.stage_solves = 4;
  result.keyframe_start.closures = 1;
  result.keyframe_start.stage_iterations = 40;
  result.keyframe_start.final_iterations = 9;
  result.keyframe_start.time_s = 0.25;
  result.evidence.valid = true;
  const OMap map = ToOMap(result, {}, {});
  const nlohmann::json solver = nlohmann::json::parse(map.reports[0].json);
  const nlohmann::json start = solver.at("keyframe_start");
  EXPECT_EQ(start["keyframes"], 30);
  EXPECT_EQ(start["stage_solves"], 4);
  EXPECT_EQ(start["closures"], 1);
  EXPECT_EQ(start["stage_iterations"], 40);
  EXPECT_EQ(start["final_iterations"], 9);
  EXPECT_FALSE(start.contains("time_s"));
  EXPECT_EQ(nlohmann::json::parse(map.timing[0].json)["keyframe_start"]["time_s"], 0.25);
  EXPECT_EQ(nlohmann::json::parse(map.reports[1].json)["log_evidence"], -7.0);
}

}  // namespace
}  // namespace oslam
