// The eval stage: the scores against the run's ground truth, written as
// JSON; a run without ground truth gives none and writes nothing.
#include "pipeline/eval_stage.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "simulated_run.h"

namespace oslam {
namespace {

namespace fs = std::filesystem;
using testing::ReadFile;

TEST(EvalStage, ScoresAgainstGroundTruthAndNothingWithout) {
  const std::string run = testing::SimulatedRun();
  ASSERT_FALSE(run.empty());
  testing::TempDir dir;
  const OMap map = testing::MapOfSimulatedRun(dir);

  EvalStageOptions eval;
  const auto metrics = RunEvalStage(map, run, dir.Path("eval.json"), eval);
  ASSERT_TRUE(metrics.has_value());
  EXPECT_EQ(ReadFile(dir.Path("eval.json")), metrics->Json());
  const std::string no_truth = testing::CopyOfRun(run, dir.Path("no_truth"));
  fs::remove_all(no_truth + "/ground_truth");
  EXPECT_FALSE(RunEvalStage(map, no_truth, dir.Path("eval2.json"), eval).has_value());
  EXPECT_FALSE(fs::exists(dir.Path("eval2.json")));
}

}  // namespace
}  // namespace oslam
