// lf-bench --four-camera (tools/lf-bench.cpp): what four-camera weights
// would gain on a grid rig (issue 37, item 2), measured before they are
// built. Printed as Markdown.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "lf/geometry/rig.h"

namespace lfbench {

// The rig with every grid cell split along its other diagonal: each pair of
// triangles that share their longest edge (a cell's diagonal) is flipped.
lf::Rig flip_cell_diagonals(const lf::Rig& rig);

// The in-between views of the grid's odd rows or columns, rendered from the
// sub-grid of its even rows and columns with the default focal surface
// (second planes, bilinear sampling) through the rig's triangulation, through
// the other diagonal, and as the mean of the two. For an eye on the camera
// plane that mean is exactly bilinear weights over the cell's four cameras
// (the tent of each diagonal is linear on the four triangles both diagonals
// cut a cell into, and the two agree with bilinear weights at the corners,
// the edge midpoints and the centre). Cell-centre views (odd row and odd
// column) are where they differ from the tent: there one diagonal blends two
// cameras, the mean four; on an edge they are the same two cameras.
void four_camera_table(const lf::Rig& rig, const std::vector<cv::Mat>& images, int W, int H);

}  // namespace lfbench
