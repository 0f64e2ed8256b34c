// The cameras every CameraModel property is checked on (camera_model_test)
// and that camera.yaml must store exactly (camera_io_test): each model, with
// its flags and mount options. A new model is added here.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "calib/hyperbolic_camera.h"
#include "calib/mei_camera.h"

namespace oslam::testing {

struct CameraCase {
  std::string name;
  std::function<std::unique_ptr<CameraModel>()> make;
};

inline std::vector<CameraCase> Cameras() {
  return {
      {"lpa", [] { return HyperbolicCamera::Preset("lpa").Clone(); }},
      {"cogniron", [] { return HyperbolicCamera::Preset("cogniron").Clone(); }},
      {"lpa_flipped_offset_decentred",
       [] {
         HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
         HyperbolicMirrorParameters p = camera.parameters();
         p.flip_image_angle = true;
         p.angle_offset_rad = 2.0;
         p.center_x_px += 3.7;
         p.center_y_px -= 5.2;
         camera.set_parameters(p);
         return camera.Clone();
       }},
      {"mei_parabolic",
       [] {
         MeiParameters p;
         p.xi = 1.0;
         p.fx_px = p.fy_px = 200.0;
         p.cx_px = 321.3;
         p.cy_px = 238.7;
         p.focus_height_m = 0.76;
         return MeiCamera(p, 640, 480, MirrorAnnulus{40.0, 236.0}).Clone();
       }},
      {"mei_hyperbolic_distorted_tilted",
       [] {
         MeiParameters p;
         p.xi = 0.9;
         p.fx_px = 260.0;
         p.fy_px = 258.0;
         p.skew = 0.3;
         p.cx_px = 402.0;
         p.cy_px = 297.0;
         p.k1 = -0.05;
         p.k2 = 0.01;
         p.p1 = 1e-3;
         p.p2 = -5e-4;
         p.focus_height_m = 1.06;
         p.mount_roll_rad = 0.02;
         p.mount_pitch_rad = -0.03;
         p.mount_yaw_rad = 0.5;
         return MeiCamera(p, 800, 600, MirrorAnnulus{45.0, 290.0}).Clone();
       }},
  };
}

}  // namespace oslam::testing
