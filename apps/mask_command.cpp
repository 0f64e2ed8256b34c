// oslam mask: the static mask of a camera rig (robot body, mirror rods, the
// blind disc) from a recording: the pixels that do not change while the
// robot drives (detect/static_mask.h, docs/your-robot.md).
#include <cstdio>
#include <memory>

#include "apps/arguments.h"
#include "apps/bindings.h"
#include "apps/commands.h"
#include "calib/camera_io.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_folder.h"
#include "core/text.h"
#include "detect/static_mask.h"

namespace oslam {

int RunMaskCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam mask RUN_DIR|VIDEO [-o MASK.png] [--camera CAMERA.yaml] [options]",
      "Finds the pixels that show the robot rather than the world (its body, the mirror's\n"
      "support rods, the camera in the blind disc): those whose brightness, relative to the\n"
      "frame's, does not change over a drive. Writes a mask image (black = ignored), by\n"
      "default RUN_DIR/mask.png, which detection then uses (docs/formats.md, mask.png).");
  arguments.AddPositional("RUN_DIR|VIDEO", "a run folder, or a video file in one");
  arguments.AddOption("output", "-o", "MASK.png",
                      "where to write the mask (default RUN_DIR/mask.png)");
  arguments.AddOption("camera", "", "CAMERA.yaml", "the camera (default RUN_DIR/camera.yaml)");
  StaticMaskOptions options;
  Bindings bindings;
  bindings.Add(&options.samples, "samples", "N", "frames read, spread over the recording");
  bindings.Add(&options.max_change, "max-change", "X",
               "largest change of a rig pixel (std of its grey level, exposure removed)");
  bindings.Add(&options.min_region_px, "min-region", "PX",
               "smaller static regions are the world's");
  bindings.Add(&options.margin_px, "margin", "PX", "grow the mask by this much");
  bindings.Declare(&arguments);
  arguments.AddFlag("quiet", "print nothing but errors");
  if (!arguments.Parse(args)) return 0;
  bindings.Apply(arguments);
  std::string why;
  if (!options.Validate(&why)) throw UsageError(why);
  const RunFolderPaths paths = RunFolderPaths::Of(arguments.Get("RUN_DIR|VIDEO"));
  const std::string output = arguments.Has("output") ? arguments.Get("output") : paths.mask;
  const bool quiet = arguments.Flag("quiet");

  const std::unique_ptr<CameraModel> camera =
      LoadCamera(arguments.Has("camera") ? arguments.Get("camera") : paths.camera);
  const FrameSource frames(arguments.Get("RUN_DIR|VIDEO"));
  Progress progress("mask", std::min(frames.size(), static_cast<size_t>(options.samples)), "frames",
                    quiet);
  const StaticMaskResult result = DetectStaticMask(
      frames, *camera, options, [&](size_t done, size_t) { progress.Update(done); });
  progress.Done(
      Format("%.1f %% of the mirror annulus is the rig's", 100.0 * result.masked_share_of_annulus));
  WriteStaticMask(result.mask, output);
  if (!quiet) std::printf("wrote %s\n", output.c_str());
  return 0;
}

}  // namespace oslam
