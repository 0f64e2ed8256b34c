// oslam view: the O-Map in an interactive VTK window, or rendered off-screen
// into a PNG (--screenshot); the drawing is in export/vtk_view.h.
#include <cstdio>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "apps/arguments.h"
#include "apps/commands.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "export/display_scene.h"
#include "export/export_files.h"
#include "export/vtk_view.h"
#include "omap/omap_json.h"

namespace oslam {

int RunViewCommand(const std::vector<std::string>& args) {
  Arguments arguments(
      "oslam view OMAP.json [--run RUN_DIR] [--screenshot FILE.png] [options]",
      "Shows the O-Map in 3D: objects in their class shapes with opacity = existence\n"
      "probability and labels, the trajectories as tubes, the floor with a metric grid, a\n"
      "legend, and the frame of the selected pose (Left/Right: previous/next pose). Mouse:\n"
      "rotate (left), pan (middle), zoom (right or wheel); Q closes. Needs a display unless\n"
      "--screenshot renders off-screen. RUN_DIR supplies class colours and shapes, odometry\n"
      "and ground truth.");
  arguments.AddPositional("OMAP", "the O-Map JSON (oslam map, oslam run)");
  arguments.AddOption("run", "", "RUN_DIR", "the run folder the map was made from");
  arguments.AddOption("screenshot", "", "FILE.png", "render off-screen into FILE.png and exit");
  arguments.AddOption("size", "", "WxH", "window or screenshot size in pixels", "1024x768");
  arguments.AddOption("pose", "", "N", "estimated pose shown as its frame (-1: none)", "-1");
  arguments.AddOption("min-existence", "", "P", "leave out objects with existence probability < P",
                      "0.1");
  arguments.AddOption("azimuth", "", "DEG",
                      "view from this compass direction (counter-clockwise from +x)", "-126");
  arguments.AddOption("elevation", "", "DEG", "view from this far above the floor", "34");
  if (!arguments.Parse(args)) return 0;

  ViewOptions view;
  int width = 0, height = 0;
  char extra = 0;
  if (std::sscanf(arguments.Get("size").c_str(), "%dx%d%c", &width, &height, &extra) != 2)
    throw UsageError("--size: '" + arguments.Get("size") + "' is not WIDTHxHEIGHT, e.g. 1024x768");
  view.width_px = width;
  view.height_px = height;
  view.selected_pose = arguments.GetInt("pose");
  view.min_existence = arguments.GetDouble("min-existence");
  view.azimuth_rad = arguments.GetDouble("azimuth") * M_PI / 180.0;
  view.elevation_rad = arguments.GetDouble("elevation") * M_PI / 180.0;
  if (!(view.elevation_rad > -M_PI / 2 && view.elevation_rad < M_PI / 2))
    throw UsageError("--elevation must be between -90 and 90 degrees");
  std::string why;
  if (!view.Validate(&why)) throw UsageError(why);

  ExportScene scene;
  scene.map = ReadOMap(arguments.Get("OMAP"));
  if (arguments.Has("run")) ReadRunContext(arguments.Get("run"), &scene);
  if (view.selected_pose >= static_cast<long>(scene.map.trajectory.size()))
    throw UsageError("--pose " + std::to_string(view.selected_pose) + ": the map has " +
                     std::to_string(scene.map.trajectory.size()) + " estimated poses");
  ExportOptions models;
  models.min_existence = view.min_existence;
  const DisplayScene display = BuildDisplayScene(scene, models);

  if (arguments.Has("screenshot")) {
    const std::string path = arguments.Get("screenshot");
    std::vector<unsigned char> png;
    if (!cv::imencode(".png", RenderView(scene, display, view), png))
      throw Error::InFile(path, "cannot encode the screenshot as PNG");
    WriteFileAtomically(path,
                        std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
    return 0;
  }
  ShowView(scene, display, view);
  return 0;
}

}  // namespace oslam
