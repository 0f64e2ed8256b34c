// Reading O-Map JSON files.
#include "omap/omap.h"

#include <fstream>

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

const char* kMap = R"({
  "format": "oslam-omap", "version": 1,
  "objects": [
    {"id": 3, "class": "green box", "base_point_m": [1.5, -0.5, 0.0], "diameter_m": 0.68,
     "height_m": 0.57, "existence_probability": 0.8, "num_detections": 12,
     "covariance": [[0.01,0,0,0,0],[0,0.01,0,0,0],[0,0,0.001,0,0],[0,0,0,0.02,0],[0,0,0,0,0.02]],
     "class_histogram": {"orange door": 0.1, "green box": 0.9}}
  ],
  "trajectory": [{"frame": 0, "x_m": 0, "y_m": 0, "theta_rad": 0},
                 {"frame": 1, "x_m": 0.2, "y_m": 0.01, "theta_rad": 0.1}]
})";

std::string ErrorFor(const std::string& text) {
  testing::TempDir dir;
  std::ofstream(dir.Path("omap.json")) << text;
  try {
    ReadOMap(dir.Path("omap.json"));
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(dir.Path("omap.json") + ": ", 0), 0u) << message;
    return message.substr(dir.Path("omap.json").size() + 2);
  }
  return "(no error)";
}

TEST(OMap, ReadsObjectsAndTrajectory) {
  testing::TempDir dir;
  std::ofstream(dir.Path("omap.json")) << kMap;
  const OMap map = ReadOMap(dir.Path("omap.json"));
  ASSERT_EQ(map.objects.size(), 1u);
  const OMapObject& box = map.objects[0];
  EXPECT_EQ(box.id, 3);
  EXPECT_EQ(box.class_name, "green box");
  EXPECT_EQ(box.base_world, Eigen::Vector3d(1.5, -0.5, 0.0));
  EXPECT_DOUBLE_EQ(box.diameter_m, 0.68);
  EXPECT_DOUBLE_EQ(box.existence_probability, 0.8);
  EXPECT_DOUBLE_EQ(box.covariance(3, 3), 0.02);
  ASSERT_EQ(box.class_histogram.size(), 2u);
  EXPECT_EQ(box.class_histogram[0].first, "green box");  // most probable first
  ASSERT_EQ(map.trajectory.size(), 2u);
  EXPECT_DOUBLE_EQ(map.trajectory[1].theta, 0.1);
}

TEST(OMap, MalformedFilesNameTheField) {
  std::string map = kMap;
  EXPECT_NE(ErrorFor("{ not json").find("not valid JSON"), std::string::npos);
  EXPECT_EQ(ErrorFor("{}"), "format: not an oslam O-Map (expected \"format\": \"oslam-omap\")");
  std::string bad = map;
  bad.replace(bad.find("\"existence_probability\": 0.8"), 28, "\"existence_probability\": 1.8");
  EXPECT_EQ(ErrorFor(bad), "objects[0].existence_probability: must be in [0, 1]");
  bad = map;
  bad.replace(bad.find("\"height_m\": 0.57,"), 17, "");
  EXPECT_EQ(ErrorFor(bad), "objects[0].height_m: missing");
  bad = map;
  bad.replace(bad.find("[1.5, -0.5, 0.0]"), 16, "[1.5, -0.5]");
  EXPECT_EQ(ErrorFor(bad), "objects[0].base_point_m: must be [x, y, z]");
}

}  // namespace
}  // namespace oslam
