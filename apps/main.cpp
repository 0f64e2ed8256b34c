// oslam: object maps from omnidirectional video and odometry.
#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core/utils/logger.hpp>

#include "apps/commands.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace {

void PrintHelp() {
  std::cout << "usage: oslam <command> [options]\n\n"
               "Builds O-Maps (3D maps of objects with class, position, size and existence\n"
               "probability) from omnidirectional robot video and odometry.\n\ncommands:\n";
  size_t width = 0;  // the longest name, so that the summaries line up
  for (const auto& command : oslam::Commands()) width = std::max(width, command.name.size());
  for (const auto& command : oslam::Commands())
    std::cout << "  " << command.name << std::string(width + 2 - command.name.size(), ' ')
              << command.summary << "\n";
  std::cout << "\nRun 'oslam <command> --help' for a command's options. 'oslam --version' prints\n"
               "the version.\n";
}

// Messages from libraries can span lines; the CLI promises one.
std::string OneLine(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  // Every failure oslam cares about comes back as an error it reports itself,
  // on one line; OpenCV's own log lines would only add to it.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  oslam::InstallInterruptCleanup();
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {
    PrintHelp();
    std::cerr << "oslam: error: no command given\n";
    return 2;
  }
  const std::string& first = args[0];
  if (first == "--help" || first == "-h" || first == "help") {
    PrintHelp();
    return 0;
  }
  if (first == "--version" || first == "version") {
    std::cout << "oslam " << OSLAM_VERSION << "\n";
    return 0;
  }
  for (const auto& command : oslam::Commands()) {
    if (command.name != first) continue;
    try {
      return command.run(std::vector<std::string>(args.begin() + 1, args.end()));
    } catch (const oslam::UsageError& e) {
      std::cerr << "oslam " << command.name << ": usage error: " << OneLine(e.what())
                << " (see 'oslam " << command.name << " --help')\n";
      return 2;
    } catch (const oslam::Error& e) {
      std::cerr << "oslam " << command.name << ": error: " << OneLine(e.what()) << "\n";
      return 1;
    } catch (const std::exception& e) {
      std::cerr << "oslam " << command.name << ": internal error: " << OneLine(e.what()) << "\n";
      return 1;
    }
  }
  std::cerr << "oslam: error: unknown command '" << first << "' (see 'oslam --help')\n";
  return 2;
}
