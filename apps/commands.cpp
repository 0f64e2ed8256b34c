#include "apps/commands.h"

namespace oslam {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"run", "video folder -> O-Map: detect, O-SLAM, export, evaluate, report", RunRunCommand},
      {"config", "print or check the configuration of 'oslam run'", RunConfigCommand},
      {"camera", "show a camera model, or write a preset as camera.yaml", RunCameraCommand},
      {"calibrate", "calibrate a catadioptric camera from checkerboard images",
       RunCalibrateCommand},
      {"train-colors", "learn class colour models from example regions", RunTrainColorsCommand},
      {"mask", "find the pixels that show the robot itself (body, mirror rods) in a recording",
       RunMaskCommand},
      {"detect", "detect objects by colour in every frame of a run", RunDetectCommand},
      {"eval-detect", "score a run's detections against its ground truth", RunEvalDetectCommand},
      {"eval", "score an O-Map against a run's ground truth", RunEvalCommand},
      {"map", "O-SLAM on a run's detections -> O-Map (--known-association: geometric SLAM)",
       RunMapCommand},
      {"export", "write an O-Map as glTF, PLY, figures and reprojection overlays",
       RunExportCommand},
      {"overlay", "draw an O-Map on a run's frames (reprojection overlays)", RunOverlayCommand},
      {"render", "figures of an O-Map: bird's-eye, perspective, trajectories", RunRenderCommand},
      {"view", "look at an O-Map in 3D (interactive, or --screenshot off-screen)", RunViewCommand},
      {"slam", "O-SLAM: association and classes by MCMC over tracks; O-Map with existence",
       RunSlamCommand},
      {"simulate", "render a simulated robot run (frames, odometry, ground truth) from a scene",
       RunSimulateCommand},
      {"simulate-landmarks",
       "a synthetic planar landmark world (city grid or park) as a data set with its truth",
       RunSimulateLandmarksCommand},
  };
  return commands;
}

}  // namespace oslam
