// Checks of one detection against its class beyond colour (docs/method.md
// §10.5, docs/detection.md "Verification"): does the blob have the size an
// object of the class would have where it stands? Colour alone takes a
// person's green trousers for a green box, a red chair for a red bottle and a
// door for an orange ball; none has the class's size where it stands.
#pragma once

#include <string>

#include "calib/camera_model.h"
#include "core/bounding_slice.h"
#include "core/run_folder.h"

namespace oslam {

// The size of the object a slice shows if its base stands at a known height
// (the floor): the base's image radius u_r gives the range, the angular width
// the diameter (the cylinder model of method.md §4.2, A.10), the slice's outer
// radius the height.
struct SupportedViewSize {
  double range_m = 0;
  double diameter_m = 0;
  double height_m = 0;
  // The top is at or beyond the mirror rim or the horizon: height_m is a
  // lower bound.
  bool top_cut = false;
};

// False when no point at `base_height_m` images at the slice's inner radius
// (the base would lie above the horizon, or the slice starts at the image
// centre).
bool SizeFromSupport(const CameraModel& camera, const BoundingSlice& slice, double base_height_m,
                     SupportedViewSize* size);

struct ViewCheckOptions {
  // Pixel error assumed on the slice's radii when its size and shape are
  // compared with the class's (the detector's base position error is about
  // 2.6 px median on the simulated runs, docs/detection.md).
  double pixel_std_px = 3.0;
  // The same on its arc width, for a class whose detector arc error was not
  // measured in training (ImageShapeModel::arc_error_px, which replaces it:
  // a plain object's blob edges are within about 1 px, so a thin
  // look-alike's shape is then measured well even where it is 5 px wide).
  double arc_std_px = 3.0;
  // Slice ends this close to the blind disc or the mirror rim are cut there.
  double edge_margin_px = 1.5;
  bool Validate(std::string* why) const;
};

// The arc-width error the view checks assume for `object_class`: its measured
// ImageShapeModel::arc_error_px, else options.arc_std_px.
double ArcStdPx(const ObjectClass& object_class, const ViewCheckOptions& options);

// The ends of a slice that lie within options.edge_margin_px of an image
// limit: there the object goes on beyond what the slice shows.
struct SliceCuts {
  bool base = false;  // the inner end at the blind disc: the base is hidden
  bool top = false;   // the outer end at the mirror rim (when the camera has one)
  bool any() const { return base || top; }
};
SliceCuts CutsOf(const MirrorAnnulus& annulus, const BoundingSlice& slice,
                 const ViewCheckOptions& options);

// Squared distance, in standard deviations, of the size a slice shows if its
// base stands at `base_height_m` from the class's size prior (diameter and
// height): per coordinate (size − prior mean)² / (prior variance + the
// variance the pixel error causes). A height cut by the rim counts only when
// it exceeds the prior mean. Infinity when the base cannot stand at that
// height (it images beyond the horizon); 0 when the slice's base touches the
// blind disc (its base is hidden, the range unknown).
double SupportedSizeSquaredDistance(const CameraModel& camera, const ObjectClass& object_class,
                                    const BoundingSlice& slice, double base_height_m,
                                    const ViewCheckOptions& options);

}  // namespace oslam
