// oslam calibrate: intrinsic calibration of a catadioptric camera from a
// folder of checkerboard images (pipeline/calibration_flow.h,
// docs/calibration.md).
#include <cmath>
#include <cstdio>

#include "apps/arguments.h"
#include "apps/bindings.h"
#include "apps/commands.h"
#include "apps/stage_bindings.h"
#include "calib/camera_io.h"
#include "core/error.h"
#include "pipeline/calibration_flow.h"

namespace oslam {
namespace {

std::string ParsePattern(const std::string& text, BoardPattern* pattern) {
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &pattern->cols, &x, &pattern->rows, &extra) != 3 ||
      (x != 'x' && x != 'X') || pattern->cols < 2 || pattern->rows < 2)
    return " expects COLSxROWS inner corners (e.g. 7x6), got '" + text + "'";
  return "";
}

void BindCalibration(CalibrationFlowOptions* o, BoardPattern* pattern, Bindings* b) {
  CalibrationOptions& c = o->calibration;
  b->AddCustom(
      "pattern", "COLSxROWS", "inner corners of the checkerboard, e.g. 7x6",
      [] { return std::string(); },
      [pattern](const std::string& text) { return ParsePattern(text, pattern); });
  b->Add(&pattern->square_m, "square", "METRES", "side of one square in metres, e.g. 0.03")
      .ShowDefault("")
      .Check([pattern] { return pattern->square_m > 0 && pattern->square_m <= 10; },
             "expects the square size in metres (e.g. 0.03)");
  b->Add(&c.model, "model", "NAME", "mei (unified model, like cv::omnidir) or hyperbolic");
  b->Add(&c.focus_height_m, "focus-height", "METRES",
         "mirror viewpoint height above the floor, measured on the robot\n"
         "(required: boards do not show it)")
      .ShowDefault("");
  b->Add(&c.mount_yaw_rad, "mount-yaw", "RAD",
         "image direction of the robot's forward axis, measured on the robot\n"
         "(required: boards do not show it; docs/calibration.md, Mount)")
      .ShowDefault("");
  b->Add(&c.mirror_a_m, "mirror-a", "METRES", "hyperbolic: mirror a (scale only)");
  b->Add(&c.mirror_b_m, "mirror-b", "METRES",
         "hyperbolic: mirror b from a data sheet (default: estimated)")
      .ShowDefault("");
  b->Add(&o->floor_board_image, "floor-board", "IMAGE",
         "a picture of the board lying flat on the floor at --board-at:\n"
         "estimates the mount instead of --focus-height/--mount-yaw")
      .ShowDefault("");
  b->AddCustom(
      "floor-pattern", "COLSxROWS", "the floor board's inner corners (default: --pattern)",
      [] { return std::string(); },
      [o](const std::string& text) { return ParsePattern(text, &o->floor_board_pattern); });
  b->Add(&o->floor_board_pattern.square_m, "floor-square", "METRES",
         "the floor board's square side (default: --square)")
      .ShowDefault("")
      .Check([o] { return o->floor_board_pattern.square_m > 0; }, "expects metres (e.g. 0.06)");
  b->AddCustom(
      "board-at", "X,Y[,YAW]",
      "where the floor board lies (robot frame, metres): its corner grid's\n"
      "centre and the direction of its rows (rad, default 0 = forward)",
      [] { return std::string(); },
      [o](const std::string& text) -> std::string {
        FloorBoardPlace& place = o->floor_board;
        char extra = 0;
        const int n = std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &place.x_m, &place.y_m,
                                  &place.yaw_rad, &extra);
        if (n == 2) place.yaw_rad = 0.0;
        if ((n != 2 && n != 3) || !std::isfinite(place.x_m) || !std::isfinite(place.y_m) ||
            !std::isfinite(place.yaw_rad) || std::hypot(place.x_m, place.y_m) > 100)
          return " expects X,Y or X,Y,YAW in metres and radians (e.g. 1.2,0 or 1.2,0,0), got '" +
                 text + "'";
        return "";
      });
  b->Add(&o->report_dir, "report-dir", "DIR", "write one PNG per view (corners and reprojections)");
}

}  // namespace

int RunCalibrateCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam calibrate IMAGES_DIR --pattern COLSxROWS --square METRES "
      "(--focus-height METRES --mount-yaw RAD | --floor-board IMAGE --board-at X,Y[,YAW]) "
      "[--model mei|hyperbolic] [--compare-opencv] [--report-dir DIR] -o CAMERA.yaml",
      "Calibrates a catadioptric camera from checkerboard images: corners on the raw images,\n"
      "Levenberg-Marquardt over intrinsics and board poses, every found board used, outlier\n"
      "views reported. Writes camera.yaml with the mirror axis vertical at --focus-height,\n"
      "turned by --mount-yaw (both measured on the robot), or at the height and yaw that a\n"
      "picture of the board lying on the floor at a known place shows (--floor-board,\n"
      "--board-at; docs/calibration.md, Mount).");
  arguments.AddPositional("IMAGES_DIR", "folder of checkerboard images (sorted by name)");
  CalibrationFlowOptions options;
  BoardPattern pattern;
  Bindings bindings;
  BindCalibration(&options, &pattern, &bindings);
  bindings.Declare(&arguments);
  arguments.AddOption("output", "-o", "CAMERA.yaml", "write the calibrated camera here");
  Bindings flags;
  flags.AddFlag(&options.compare_opencv, "compare-opencv",
                "also run cv::omnidir::calibrate on the same corners");
  flags.AddFlag(&options.refine_with_corner_subpix, "subpix",
                "also refine corners with cv::cornerSubPix (worse on our sets)");
  flags.AddNegatedFlag(&options.detect_rim, "no-rim",
                       "do not detect the mirror rim / blind disc for the annulus");
  flags.Declare(&arguments);
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  if (!arguments.Has("pattern")) throw UsageError("missing --pattern COLSxROWS");
  if (!arguments.Has("square")) throw UsageError("missing --square METRES");
  if (!arguments.Has("output")) throw UsageError("missing -o CAMERA.yaml");
  // The mount is measured or estimated from a floor board, never a silent
  // default that would look calibrated.
  const bool floor_board = arguments.Has("floor-board") || arguments.Has("board-at");
  if (floor_board) {
    if (!arguments.Has("floor-board")) throw UsageError("--board-at needs --floor-board IMAGE");
    if (!arguments.Has("board-at"))
      throw UsageError("--floor-board needs --board-at X,Y[,YAW] (where the board lies)");
    if (arguments.Has("focus-height") || arguments.Has("mount-yaw"))
      throw UsageError(
          "give the mount either measured (--focus-height, --mount-yaw) or from a floor board "
          "(--floor-board, --board-at), not both");
  } else if (!arguments.Has("focus-height"))
    throw UsageError(
        "missing --focus-height METRES (the mirror viewpoint's height above the floor is not "
        "estimated from boards held around the mirror: measure it on the robot, or give "
        "--floor-board and --board-at)");
  if (!floor_board && !arguments.Has("mount-yaw"))
    throw UsageError(
        "missing --mount-yaw RAD (the image direction of the robot's forward axis is not "
        "estimated from boards held around the mirror: measure it, or give --floor-board and "
        "--board-at; docs/calibration.md)");
  bindings.Apply(arguments);
  flags.Apply(arguments);
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);

  const bool quiet = arguments.Flag("quiet");
  const CalibrationResult result = CalibrateFromImages(arguments.Get("IMAGES_DIR"), pattern,
                                                       options, CommandOutput("calibrate", quiet));
  SaveCamera(*result.camera, arguments.Get("output"));
  if (!quiet) std::printf("wrote %s\n", arguments.Get("output").c_str());
  return 0;
}

}  // namespace oslam
