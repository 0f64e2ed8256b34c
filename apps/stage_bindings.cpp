#include "apps/stage_bindings.h"

#include <cstdio>

#include "export/export_files.h"

namespace oslam {

void BindDetectOptions(DetectStageOptions* o, Bindings* b) {
  BlobDetectorOptions& d = o->detector;
  b->Add(&o->debug_images_dir, "debug-images", "DIR",
         "also write each frame with its slices drawn");
  b->Add(&d.min_area_px, "min-area", "PX", "smallest blob kept, in pixels")
      .Key("min_area_px", "smallest colour blob kept, pixels");
  b->Add(&d.opening_radius_px, "opening", "PX", "radius of the morphological opening, 0 = off")
      .Key("opening_radius_px", "morphological opening, 0 = off");
  b->AddChoice(&d.colour.shape,
               {{"yuv", ColourBoxShape::kYuv}, {"scaled", ColourBoxShape::kBrightnessScaled}},
               "colour-box", "yuv|scaled",
               "class colour region: 'yuv' = the thesis' mean ± k·σ box; 'scaled' = its chroma "
               "scaled with brightness (robust to dim light)")
      .Key("colour_box",
           "yuv = the thesis' mean +- k sigma YUV box; scaled = chroma scaled with brightness");
  b->Add(&d.colour.brightness_range, "brightness-range", "R",
         "with --colour-box scaled: accept brightness from 1/R to R times the examples' range")
      .Key("brightness_range",
           "colour_box scaled: accept brightness from 1/R to R times the examples' range");
  b->AddInvertedFlag(&d.separate_look_alikes, "keep-look-alikes",
                     "keep every class a blob's colour matches (the thesis); by default, where "
                     "two classes' blobs are the same pixels, only the one whose colour and "
                     "learnt image shape fit better is kept")
      .Key("keep_look_alikes",
           "1: keep every class a blob's colour matches (thesis); 0: of look-alike classes on "
           "the same pixels keep the one whose colour and image shape fit better");
  b->AddNumberOrInfinity(&d.max_shape_distance, "max-shape-distance", "SIGMAS",
                         "drop detections whose slice elongation is further than this from "
                         "their class's image shape (inf = off)")
      .Key("max_shape_distance",
           "drop detections whose slice elongation is further than this many sigmas from their "
           "class's image shape; inf = off");
  b->AddNumberOrInfinity(&d.max_blob_colour_distance, "max-blob-colour-distance", "SIGMAS",
                         "drop blobs whose mean colour is further than this from their class's "
                         "learnt blob colour (inf = off)")
      .Key("max_blob_colour_distance",
           "drop colour blobs whose mean colour is further than this many sigmas from the "
           "blob colour learnt for their class; inf = off");
  b->AddNumberOrInfinity(&d.max_view_distance, "max-view-distance", "SIGMAS",
                         "drop detections whose image shape and size standing on the floor are "
                         "further than this from their class's (inf = off)")
      .Key("max_view_distance",
           "drop detections whose image shape plus the size they would have standing on the "
           "floor are further than this many sigmas from their class's; inf = off");
  b->Add(&d.fragment_gap_px, "fragment-gap", "PX",
         "same-class blobs this close in one frame are checked together as one view")
      .Key("fragment_gap_px", "same-class blobs this close in one frame are checked as one view");
  b->AddNegatedFlag(&d.drop_fragments, "keep-fragments",
                    "keep same-class pieces that fail their class together (e.g. two objects "
                    "side by side)")
      .Key("drop_fragments",
           "1: drop same-class pieces that fail their class together (an occluded larger thing)");
  b->AddNegatedFlag(&d.join_fragments, "no-join-fragments",
                    "keep the pieces of a blob cut by stripes or a rod as separate detections")
      .Key("join_fragments",
           "1: report same-class pieces that fit their class better together as one detection");
  b->Add(&o->sift_templates, "sift-templates", "FILE.yaml",
         "keep a detection of a class with templates only if SIFT verifies it")
      .Key("sift_templates", "templates.yaml for SIFT verification; empty = colour only");
  b->Add(&o->threads, "threads", "N", "frames decoded and searched at once (0 = one per core)")
      .Key("threads", "frames decoded and searched at once, 0 = one per core (same output)")
      .Check([o] { return o->threads >= 0; }, "must be >= 0");
  b->AddFlag(&o->skip_bad_frames, "skip-bad-frames", "warn about unreadable frames and go on")
      .Key("skip_bad_frames", "1: warn about unreadable frames and go on instead of stopping");
  b->Add(&o->mask, "mask", "FILE",
         "static mask image (0 = ignore: robot body, mirror rods); default RUN/mask.png when "
         "present, 'none' = no mask")
      .Key("mask",
           "static mask image, black = ignored (robot body, mirror rods); empty = RUN/mask.png "
           "when present; none = no mask")
      .ShowDefault("");
}

void BindExportOptions(ExportStageOptions* o, Bindings* b) {
  b->Add(&o->min_existence, "min-existence", "P",
         "leave out objects with existence probability < P")
      .Key("min_existence", "leave out objects with a lower existence probability");
  b->AddFlag(&o->overlays, "overlays",
             "also draw the map on the run's frames (overlays/NNNNNN.jpg)")
      .Key("overlays", "1: draw the map on every frame");
  b->Add(&o->overlay_frames, "frames", "LIST", "overlay only these frames, e.g. 0,10,20-30")
      .Key("overlay_frames", "only these frames, e.g. 0,10,20-30");
  b->Add(&o->overlay_format, "overlay-format", "jpg|png",
         "overlay image format (png: lossless, about 3x slower)")
      .Key("overlay_format", "jpg, or png: lossless, about 3x slower")
      .Check([o] { return ParseOverlayFormat(o->overlay_format).has_value(); },
             "must be jpg or png");
  b->Add(&o->threads, "threads", "N", "overlays drawn and written at once (0 = one per core)")
      .Key("threads", "overlays drawn and written at once, 0 = one per core (same output)")
      .Check([o] { return o->threads >= 0; }, "must be >= 0");
  b->Add(&o->figure_size_px, "figure-size", "PX", "width and height of the figures")
      .Key("figure_size_px", "width and height of the figures");
  b->AddNegatedFlag(&o->floor_grid, "no-grid", "no floor grid in the glTF")
      .Key("floor_grid", "1: a floor grid in the glTF");
  b->Add(&o->camera_every, "cameras", "N", "glTF: a camera pyramid at every Nth estimated pose")
      .Key("camera_every", "glTF: a camera pyramid at every Nth estimated pose, 0 = none")
      .Check([o] { return o->camera_every >= 0; }, "must be >= 0");
  b->AddFlag(&o->ascii_ply, "ascii-ply", "write ASCII PLY instead of binary")
      .Key("ascii_ply", "1: ASCII PLY instead of binary");
}

void BindEvalOptions(EvalStageOptions* o, Bindings* b) {
  b->Add(&o->metrics.existence_threshold, "threshold", "P",
         "objects with existence probability <= P are left out")
      .Key("threshold", "objects at or below this existence probability are not in the map");
  b->Add(&o->metrics.match_gate_m, "gate", "M", "largest horizontal base-point distance of a match")
      .Key("gate_m", "largest base-point distance of a match, m");
}

void BindFrameOptions(FrameSelectionOptions* o, Bindings* b) {
  b->Add(&o->time_offset_s, "", "S", "odometry time of a frame = frame time + this offset")
      .Key("time_offset_s", "odometry clock minus frame clock, s (odometry by time only)");
  b->Add(&o->min_distance_m, "", "M", "keep a frame once the robot moved this far")
      .Key("min_distance_m",
           "keep a frame once the robot moved this far since the last kept one, m (or turned)");
  b->Add(&o->min_turn_rad, "", "RAD", "... or turned this much")
      .Key("min_turn_rad", "... or turned this much, rad (0.1745 = 10 deg)");
  b->Add(&o->step_tolerance, "", "F", "a step of (1 - F) x the distance or turn counts as reached")
      .Key("step_tolerance",
           "a step of at least (1 - this) x min_distance_m or min_turn_rad counts as reached "
           "(stop-and-go steps of exactly 0.2 m log a little less)");
  b->Add(&o->stride, "", "N", "keep every N-th frame instead (0: by distance and turn)")
      .Key("stride", "> 0: keep every N-th frame in the odometry's span instead; 1 = all");
}

StageOutput CommandOutput(const std::string& command, bool quiet) {
  StageOutput output;
  output.quiet = quiet;
  output.print = [](const std::string& line) {
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  };
  output.warn = [command](const std::string& message) {
    std::fprintf(stderr, "oslam %s: warning: %s\n", command.c_str(), message.c_str());
  };
  return output;
}

}  // namespace oslam
