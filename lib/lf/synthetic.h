// Synthetic rigs and analytically rendered images, for tests and benchmarks.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

#include "lf/rig.h"

namespace lf {

// rows x cols grid of identical pinhole cameras on the plane z = 0 (rig
// units), spacing `spacing`, looking along +z, image width x height, vertical
// field of view `vfov_deg`. With rot_jitter_deg > 0 each camera gets a random
// rotation of up to that angle about a random axis (fixed seed).
Rig synthetic_grid_rig(int rows, int cols, double spacing, int width, int height,
                       double vfov_deg = 40.0, double rot_jitter_deg = 0.0, uint64_t seed = 1);

// Colour of the procedural texture at plane coordinates (x, y): a smooth
// sum of sinusoids (band-limited, so bilinear resampling is accurate), 8-bit
// BGR in [30, 225]. `period` sets the finest wavelength (rig units).
cv::Vec3d texture_colour(double x, double y, double period);

// Image of the textured plane z = depth seen by `cam` (lens distortion
// included), CV_8UC4, alpha 255. Pixels whose ray misses the plane are black.
cv::Mat render_textured_plane(const Camera& cam, double depth, double period);

}  // namespace lf
