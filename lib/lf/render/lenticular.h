// Interleaving a quilt (lf/render/quilt.h) for a lenticular light-field display
// (the Looking Glass family): each sub-pixel of the panel shows one view,
// chosen by where it lies under the slanted lenticules. The formula is the
// one the display's published shader (HoloPlay Core, "HoloPlayShaders.h")
// applies, from the display's calibration ("visual.json"):
//
//   pitch' = pitch * screenW / DPI * cos(atan(1 / slope))   (lenticules per screen width)
//   tilt   = screenH / (screenW * slope)
//   subp   = 1 / (3 * screenW)                               (a sub-pixel, in screen widths)
//   for sub-pixel c (0, 1, 2 left to right) of the pixel whose centre is
//   (u, v) in [0, 1]^2 (u = (x + 0.5) / screenW from the left, v from the
//   bottom; with flipImageX, u = 1 - u):
//     a = (u + c * subp + v * tilt) * pitch' - center,  a = a - floor(a)
//     with invView: a = 1 - a
//     view = min(floor(a * views), views - 1)
//   and colour channel k (R, G, B) of the panel pixel is channel k of view
//   `view` at (u, v) of its tile (nearest sample), where the view is the
//   one of sub-pixel c = k, or c = 2 - k with flipSubp (BGR panels).
//
// All of this is computed in single precision, as a shader does, so that
// the CPU kernel here and the GL shader (lf/render/gl_render.h) choose the same
// view for all but the sub-pixels within float rounding of a boundary.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "lf/render/quilt.h"

namespace lf {

struct DisplayCalibration {
  double pitch = 0;   // lenticules per inch, along the lenticule's normal
  double slope = 0;   // lenticule slope (screen rows per column step), != 0
  double center = 0;  // phase of the first view, in lenticules
  double dpi = 0;     // panel pixels per inch
  int screen_w = 0;   // panel size, pixels
  int screen_h = 0;
  bool inv_view = false;      // views run right to left under a lenticule
  bool flip_image_x = false;  // the panel is mirrored horizontally
  bool flip_subp = false;     // BGR sub-pixel order
  double view_cone = 40;      // degrees (the display's; informative here)
};

// Reads a display's calibration JSON: the Looking Glass "visual.json" form,
// {"pitch": {"value": 47.6}, ...}, or plain numbers {"pitch": 47.6, ...}.
// Fields: pitch, slope, center, DPI, screenW, screenH (required), invView,
// flipImageX, flipSubp (0/1), viewCone (optional). Throws
// std::invalid_argument naming the field that is missing, not finite or
// out of range (pitch, DPI > 0; slope != 0; screen 1..16384), or for text
// that is not JSON. `what` names the source in messages.
DisplayCalibration parse_display_calibration(const std::string& json,
                                             const std::string& what = "calibration");
DisplayCalibration load_display_calibration(const std::string& path);

// The derived shader constants (single precision, as the shader's).
struct LenticularConstants {
  float pitch = 0, tilt = 0, subp = 0, center = 0;
};
LenticularConstants lenticular_constants(const DisplayCalibration& cal);

// The view that sub-pixel c (0..2, left to right on the panel) of panel
// pixel (x, y) (y = 0 the top row) shows, of `views`.
int lenticular_view(const DisplayCalibration& cal, const LenticularConstants& k, int views, int x,
                    int y, int c);

// The panel image (cal.screen_w x cal.screen_h, CV_8UC4, RGBA, alpha 255)
// interleaved from `quilt` (CV_8UC4 RGBA, a whole number of the layout's
// tiles, the first view at the bottom-left). `out` is (re)allocated.
// Rows in parallel. Throws std::invalid_argument on a bad layout or image.
void interleave_quilt(const DisplayCalibration& cal, const Quilt& layout, const cv::Mat& quilt,
                      cv::Mat& out);

}  // namespace lf
