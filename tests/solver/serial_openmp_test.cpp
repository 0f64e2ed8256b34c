#include "solver/serial_openmp.h"

#include <atomic>
#include <thread>

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <omp.h>

namespace oslam {
namespace {

// What the body of one `#pragma omp parallel num_threads(2)` saw.
struct Region {
  int runs = 0;
  int level = -1, threads = -1, thread_number = -1;
  bool on_calling_thread = false;
};

Region OpenRegion() {
  Region region;
  std::atomic<int> runs{0};
  const std::thread::id caller = std::this_thread::get_id();
#pragma omp parallel num_threads(2)
  {
    ++runs;
#pragma omp master
    {
      region.level = omp_get_level();
      region.threads = omp_get_num_threads();
      region.thread_number = omp_get_thread_num();
      region.on_calling_thread = std::this_thread::get_id() == caller;
    }
  }
  region.runs = runs;
  return region;
}

TEST(SerialOpenMpTest, OutsideAScopeRegionsGoToLibgomp) {
  EXPECT_FALSE(SerialOpenMpScope::Active());
  const Region region = OpenRegion();
  EXPECT_EQ(region.level, 1);  // libgomp made a team
  EXPECT_EQ(region.runs, region.threads);
}

TEST(SerialOpenMpTest, InsideAScopeARegionRunsOnceOnTheCallingThreadWithoutLibgomp) {
  const SerialOpenMpScope serial;
  EXPECT_TRUE(SerialOpenMpScope::Active());
  const Region region = OpenRegion();
  EXPECT_EQ(region.runs, 1);
  EXPECT_EQ(region.threads, 1);
  EXPECT_EQ(region.thread_number, 0);
  EXPECT_TRUE(region.on_calling_thread);
  EXPECT_EQ(region.level, 0);  // called directly: libgomp never saw it
}

TEST(SerialOpenMpTest, TheScopeIsPerThreadNestsAndRestoresTheSetting) {
  omp_set_max_active_levels(3);
  {
    const SerialOpenMpScope outer;
    EXPECT_EQ(omp_get_max_active_levels(), 0);
    {
      const SerialOpenMpScope inner;
      EXPECT_TRUE(SerialOpenMpScope::Active());
    }
    EXPECT_TRUE(SerialOpenMpScope::Active());
    EXPECT_EQ(omp_get_max_active_levels(), 0);
    // Another thread is not inside the scope.
    bool active_there = true;
    std::thread([&] { active_there = SerialOpenMpScope::Active(); }).join();
    EXPECT_FALSE(active_there);
  }
  EXPECT_FALSE(SerialOpenMpScope::Active());
  EXPECT_EQ(omp_get_max_active_levels(), 3);
}

// Inside a user's parallel region the body must not run directly: it would
// see the enclosing team's thread count and number. It goes to libgomp as
// a nested team of one.
TEST(SerialOpenMpTest, InsideAUsersRegionANestedRegionGoesToLibgompAsATeamOfOne) {
  Region nested[2];
#pragma omp parallel num_threads(2)
  {
    const SerialOpenMpScope serial;
    const int t = omp_get_thread_num();
    if (t < 2) nested[t] = OpenRegion();
  }
  for (const Region& region : nested) {
    if (region.runs == 0) continue;  // a thread the runtime did not give
    EXPECT_EQ(region.runs, 1);
    EXPECT_EQ(region.threads, 1);
    EXPECT_EQ(region.thread_number, 0);
    EXPECT_EQ(region.level, 2);
  }
}

TEST(SerialOpenMpTest, OpenBlasRunsOnOneThread) {
  using GetNumThreads = int (*)();
  const auto get = reinterpret_cast<GetNumThreads>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  if (!get) GTEST_SKIP() << "the process's BLAS is not OpenBLAS";
  UseOneBlasThread();
  EXPECT_EQ(get(), 1);
}

}  // namespace
}  // namespace oslam
