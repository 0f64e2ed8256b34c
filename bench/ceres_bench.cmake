# Ceres comparison of the geometric solver. Benchmark-only and
# optional: built when Debian's libceres-dev is installed, skipped otherwise.
find_package(Ceres QUIET)
if(Ceres_FOUND)
  oslam_add_bench(ceres_bench SOURCES ceres_bench.cpp LIBS oslam_slam Ceres::ceres)
else()
  message(STATUS "Ceres not found (apt-get install libceres-dev): ceres_bench is skipped")
endif()
