// The oslam subcommands, registered in one place (commands.cpp).
#pragma once

#include <string>
#include <vector>

namespace oslam {

struct Command {
  std::string name;
  std::string summary;  // one line for `oslam --help`
  // Parses its own arguments (argv after the command name). Returns the exit
  // code; throws UsageError (exit 2) or Error (exit 1).
  int (*run)(const std::vector<std::string>& args);
};

const std::vector<Command>& Commands();

// One function per subcommand, each in its own file.
int RunCameraCommand(const std::vector<std::string>& args);
int RunConfigCommand(const std::vector<std::string>& args);
int RunRunCommand(const std::vector<std::string>& args);
int RunCalibrateCommand(const std::vector<std::string>& args);
int RunDetectCommand(const std::vector<std::string>& args);
int RunMaskCommand(const std::vector<std::string>& args);
int RunEvalDetectCommand(const std::vector<std::string>& args);
int RunEvalCommand(const std::vector<std::string>& args);
int RunMapCommand(const std::vector<std::string>& args);  // apps/map_modes.h
int RunTrainColorsCommand(const std::vector<std::string>& args);
int RunSlamCommand(const std::vector<std::string>& args);
int RunSimulateCommand(const std::vector<std::string>& args);
int RunSimulateLandmarksCommand(const std::vector<std::string>& args);
int RunExportCommand(const std::vector<std::string>& args);
int RunOverlayCommand(const std::vector<std::string>& args);
int RunRenderCommand(const std::vector<std::string>& args);
int RunViewCommand(const std::vector<std::string>& args);

}  // namespace oslam
