// ParallelFor: every index once, the same failure reported whatever the
// thread count; the frame cache: frames decoded once per path while enabled.
#include <atomic>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "core/parallel.h"
#include "core/run_folder.h"
#include "test_util.h"

namespace oslam {
namespace {

TEST(ParallelFor, RunsEveryIndexOnceWithAnyThreadCount) {
  for (int threads : {0, 1, 2, 5}) {
    std::vector<std::atomic<int>> calls(1000);
    ParallelFor(0, calls.size(), threads, [&](size_t i) { ++calls[i]; });
    for (size_t i = 0; i < calls.size(); ++i) ASSERT_EQ(calls[i], 1) << i << ", " << threads;
  }
  ParallelFor(3, 3, 2, [](size_t) { FAIL() << "empty range"; });
  EXPECT_EQ(ThreadCount(2, 1), 1);
  EXPECT_EQ(ThreadCount(3, 100), 3);
  EXPECT_GE(ThreadCount(0, 100), 1);
}

TEST(ParallelFor, RethrowsTheLowestFailingIndexAndFinishesTheOnesBefore) {
  for (int repeat = 0; repeat < 20; ++repeat) {
    for (int threads : {1, 2, 4}) {
      std::vector<std::atomic<int>> done(200);
      try {
        ParallelFor(0, done.size(), threads, [&](size_t i) {
          if (i == 150 || i == 90 || i == 91) throw std::runtime_error(std::to_string(i));
          ++done[i];
        });
        ADD_FAILURE() << "no exception";
      } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "90") << threads << " threads";
      }
      for (size_t i = 0; i < 90; ++i) ASSERT_EQ(done[i], 1) << i << ", " << threads;
    }
  }
}

TEST(FrameCache, FramesAreDecodedOncePerPathWhileEnabled) {
  testing::TempDir run;
  std::filesystem::create_directories(run.Path("frames"));
  const std::string frame = run.Path("frames/000000.png");
  ASSERT_TRUE(cv::imwrite(frame, cv::Mat(4, 6, CV_8UC3, cv::Scalar(10, 20, 30))));
  const FrameSource frames(run.Path());

  SetFrameCacheLimit(1 << 20);
  EXPECT_EQ(frames.Read(0).at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
  ASSERT_TRUE(cv::imwrite(frame, cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3))));
  EXPECT_EQ(frames.Read(0).at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30)) << "not from the cache";

  SetFrameCacheLimit(0);  // off: kept frames dropped, the file read again
  EXPECT_EQ(frames.Read(0).at<cv::Vec3b>(0, 0), cv::Vec3b(1, 2, 3));
  ASSERT_TRUE(cv::imwrite(frame, cv::Mat(4, 6, CV_8UC3, cv::Scalar(4, 5, 6))));
  EXPECT_EQ(frames.Read(0).at<cv::Vec3b>(0, 0), cv::Vec3b(4, 5, 6));

  SetFrameCacheLimit(10);  // smaller than one frame: nothing kept
  frames.Read(0);
  ASSERT_TRUE(cv::imwrite(frame, cv::Mat(4, 6, CV_8UC3, cv::Scalar(7, 8, 9))));
  EXPECT_EQ(frames.Read(0).at<cv::Vec3b>(0, 0), cv::Vec3b(7, 8, 9));
  SetFrameCacheLimit(0);
}

}  // namespace
}  // namespace oslam
