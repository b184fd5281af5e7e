// Rig importers for the light-field datasets in ../shared/data (formats and
// conventions: shared/data/README.md) and image loading.
//
// World frames chosen by the importers (all right-handed, cameras looking
// along +z, x right, y down, so that rectified datasets keep R = I):
//  * Stanford light slab ("out_RR_CC_<Y>_<X>_.png"): camera centre (X, Y, 0) in
//    the archive's own parallax units. The images are rectified onto a
//    reference plane, i.e. parallel pinhole cameras whose principal points
//    shift with position. The archive's focal parameter `a` (pixels of image
//    shift per unit of camera displacement) maps to the plane z = f / (a_inf - a)
//    parallel to the camera plane. Scale and the depth of the reference plane
//    are not published; we fix f = image width (px) and a_inf = 0.5, which puts
//    the whole useful range a = -0.45 .. 0.15 at positive depth. Renders from
//    the camera plane do not depend on this choice.
//  * HCI (parameters.cfg): metres, centre camera at the origin, camera (row,
//    col) at ((col-4) b, (row-4) b, 0); f = focal_mm / sensor_mm * max(W, H);
//    principal points shifted so that zero disparity lies at focus_distance_m.
//    a_inf = f / focus_distance; the HCI disparity d (px per view step) is
//    a = -d / b.
//  * Blender "shop": metres, C = (x, -y, 0)/1000 from the file name fields;
//    f = focal_mm / sensor_mm * W; unshifted principal points (a_inf = 0).
//  * Middlebury multi-view (*_par.txt): K, R, t as published (metres); no
//    grid (an unstructured ring, triangulated by Delaunay on its camera plane).
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/geometry/rig.h"

namespace lf {

// Recognised kinds: "stanford", "hci", "blender-shop", "middlebury".
std::string detect_dataset(const std::string& folder);  // "" if none
// Imports by kind (detect_dataset when kind is empty). Throws
// std::runtime_error naming the folder/file and what is wrong.
Rig import_dataset(const std::string& folder, const std::string& kind = "");
Rig import_stanford(const std::string& folder);
Rig import_hci(const std::string& folder);
Rig import_blender_shop(const std::string& folder);
Rig import_middlebury(const std::string& folder);

// Loads a rig from a rig file (*.json) or a dataset folder.
Rig load_rig_or_dataset(const std::string& path);

// Reads every camera's image, converts it to 8-bit BGRA (alpha 255) and
// resizes it to the camera's size in `rig` (INTER_AREA). Decodes in parallel.
// `progress(done, total)` is called as images arrive (any thread). Throws
// std::runtime_error naming the file that is missing or unreadable.
std::vector<cv::Mat> load_images(const Rig& rig,
                                 const std::function<void(int, int)>& progress = {});

// Reads a PFM file (little- or big-endian, 1 or 3 channels, rows flipped to
// top-down). Throws std::runtime_error on malformed files.
cv::Mat read_pfm(const std::string& path);

}  // namespace lf
