// Operations on rigs: sub-grids and rescaled images (lf/geometry/rig.h).
#pragma once

#include "lf/geometry/rig.h"

namespace lf {

// Keeps the cameras of grid rows [r0, r0+rows) and cols [c0, c0+cols).
Rig grid_block(const Rig& rig, int r0, int c0, int rows, int cols);

// The k x k sub-grid of rows and columns spread evenly over the whole grid
// (first and last included; k >= 2), as the paper's Figure 6 spreads 4, 16
// and 64 cameras over the array. Throws std::invalid_argument if the grid
// has fewer than k rows or columns.
Rig grid_spread(const Rig& rig, int k);

// Cameras dealt to `hosts` camera hosts in contiguous blocks of the grid,
// for partial sums (lf/render/composite.h sum_fragments: neighbours' fragments
// overlap, so a block's sum is small): the grid is cut into br x bc blocks
// (br * bc = hosts, the factorisation whose blocks are the most square),
// rows and columns split as evenly as they go. Returns each camera's host
// (0..hosts-1) in rig order. A rig without a grid is cut into runs of rig
// order. Throws std::invalid_argument for hosts < 1 or more hosts than
// cameras.
std::vector<int> host_blocks(const Rig& rig, int hosts);

// Same rig with every image resized by `scale` (image sizes rounded, intrinsics
// rescaled per axis).
Rig scale_rig(const Rig& rig, double scale);

}  // namespace lf
