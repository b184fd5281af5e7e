// Synthetic rigs and analytically rendered images, for tests and benchmarks.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "lf/geometry/rig.h"

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

// A dynamic scene with ground truth, scaled to a rig: a textured background
// plane parallel to the camera plane at depth `far_depth`, and a textured
// disc of radius `disc_radius` at depth `near_depth` whose centre moves on a
// circle of radius `orbit_radius` about the array's axis, one turn per
// `period_s` seconds. Depths are along the camera-plane normal from its
// origin (rig units). Defaults from the rig's camera spacing s: far 60 s,
// near 25 s, disc 5 s, orbit 4 s, period 4 s.
struct SyntheticScene {
  cv::Vec3d origin, u, v, normal;  // the rig's camera plane
  double far_depth = 0, near_depth = 0, disc_radius = 0, orbit_radius = 0;
  double period_s = 4.0;
  double far_period = 0, near_period = 0;  // texture wavelengths, rig units
  // Thin structures: with bar_width > 0 the disc is a grating, only its
  // stripes across u, bar_width wide and bar_pitch apart on average
  // (irregularly spaced, so that a plane sweep cannot alias them; rig
  // units) are there; the background shows between them.
  double bar_width = 0, bar_pitch = 0;

  static SyntheticScene for_rig(const Rig& rig);
  // Image of the scene at time t (seconds) from `cam` (distortion included),
  // CV_8UC4 with the channel order given by `rgba` (else BGRA), alpha 255.
  cv::Mat render(const Camera& cam, double t, bool rgba = true) const;
  // Centre of the disc at time t.
  cv::Vec3d disc_centre(double t) const;
};

// Makes `rig` a dataset: writes each camera's view of SyntheticScene::for_rig(rig)
// at time t (seconds) as `dir`/<camera name>.png (8-bit BGR, lossless) and returns
// the rig with each camera's image set to that file (absolute path). `dir`
// must exist. Throws std::runtime_error when a file cannot be written.
// Used by lf-rig --synthetic --images (e.g. a 16 x 16 rig for the scaling
// benchmark; Chess has 81 cameras).
Rig write_synthetic_images(Rig rig, const std::string& dir, double t = 0.0);

// Sensor noise (lfcamsrc `noise`): zero-mean Gaussian noise of standard
// deviation `sigma` (8-bit levels) added to each colour channel of each
// pixel of `rgba` (CV_8UC4; alpha untouched), saturating, drawn from a seed
// of camera `camera_id` and frame `frame`, so a run is reproducible.
cv::Mat with_sensor_noise(const cv::Mat& rgba, double sigma, int camera_id, uint64_t frame);

}  // namespace lf
