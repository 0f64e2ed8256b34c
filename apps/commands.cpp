#include "apps/commands.h"

namespace oslam {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"camera", "show a camera model, or write a preset as camera.yaml", RunCameraCommand},
  };
  return commands;
}

}  // namespace oslam
