// The calibration flow's input checks and report: a missing folder, a
// folder without images, images of two sizes, and views without a board
// (each named in the report, then too few to calibrate).
#include "pipeline/calibration_flow.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "test_util.h"

namespace oslam {
namespace {

std::string Message(const std::string& dir, const CalibrationFlowOptions& options,
                    const StageOutput& output = {}) {
  try {
    CalibrateFromImages(dir, {7, 6, 0.03}, options, output);
  } catch (const Error& e) {
    return e.what();
  }
  return "(calibrated)";
}

TEST(CalibrationFlow, BadImageFoldersAreNamed) {
  testing::TempDir dir;
  const CalibrationFlowOptions options;
  EXPECT_EQ(Message(dir.Path("missing"), options), dir.Path("missing") + ": not a directory");
  EXPECT_EQ(Message(dir.Path(), options),
            dir.Path() + ": no images (.jpg .png .bmp .tif .pgm .ppm)");
  cv::imwrite(dir.Path("a.png"), cv::Mat(48, 64, CV_8UC1, cv::Scalar(128)));
  cv::imwrite(dir.Path("b.png"), cv::Mat(40, 64, CV_8UC1, cv::Scalar(128)));
  EXPECT_EQ(Message(dir.Path(), options),
            dir.Path("b.png") + ": image is 64x40, the first one 64x48");
}

TEST(CalibrationFlow, ViewsWithoutABoardAreReportedThenTooFewToCalibrate) {
  testing::TempDir dir;
  for (const char* name : {"1.png", "2.png", "3.png"})
    cv::imwrite(dir.Path(name), cv::Mat(48, 64, CV_8UC1, cv::Scalar(128)));
  CalibrationFlowOptions options;
  options.detect_rim = false;
  std::vector<std::string> lines;
  StageOutput output;
  output.print = [&](const std::string& line) { lines.push_back(line); };
  EXPECT_NE(Message(dir.Path(), options, output), "(calibrated)");
  ASSERT_GE(lines.size(), 3u);
  EXPECT_EQ(lines[0], "corners: 1.png                    BOARD NOT FOUND (view not used)");

  options.calibration.model = "fisheye";
  std::string why;
  EXPECT_FALSE(options.Validate(&why));
  EXPECT_NE(Message(dir.Path(), options).find("fisheye"), std::string::npos);
}

}  // namespace
}  // namespace oslam
