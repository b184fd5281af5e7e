// Operations on rigs: sub-grids and rescaled images (lf/rig.h).
#pragma once

#include "lf/rig.h"

namespace lf {

// Keeps the cameras of grid rows [r0, r0+rows) and cols [c0, c0+cols).
Rig grid_block(const Rig& rig, int r0, int c0, int rows, int cols);

// The k x k sub-grid of rows and columns spread evenly over the whole grid
// (first and last included; k >= 2), as the paper's Figure 6 spreads 4, 16
// and 64 cameras over the array. Throws std::invalid_argument if the grid
// has fewer than k rows or columns.
Rig grid_spread(const Rig& rig, int k);

// Same rig with every image resized by `scale` (image sizes rounded, intrinsics
// rescaled per axis).
Rig scale_rig(const Rig& rig, double scale);

}  // namespace lf
