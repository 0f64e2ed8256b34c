// oslam map: full O-SLAM by default (issue 7), geometric SLAM with the
// simulator's association given by --known-association (issue 6), landmark
// SLAM on range-bearing data with --landmarks (issue 10).
#include <algorithm>
#include <iostream>

#include "apps/commands.h"

namespace oslam {

int RunMapDispatchCommand(const std::vector<std::string>& args) {
  const auto has = [&](const char* flag) { return std::find(args.begin(), args.end(), flag) != args.end(); };
  if (has("--known-association")) return RunMapCommand(args);
  for (const std::string& arg : args)
    if (arg == "--landmarks" || arg.rfind("--landmarks=", 0) == 0)
      return RunLandmarkMapCommand(args);
  if (has("--help") || has("-h")) {
    std::cout << "oslam map runs O-SLAM (the options below, as 'oslam slam'); with\n"
                 "--known-association it runs geometric SLAM on the ground-truth association\n"
                 "instead (see 'oslam map --known-association --help'); with --landmarks FILE\n"
                 "it runs landmark SLAM on a range-bearing data set (see\n"
                 "'oslam map --landmarks x --help').\n\n";
  }
  return RunSlamCommand(args);
}

}  // namespace oslam
