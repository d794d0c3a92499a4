// Stage `grid`: per grid cell, up to storedDisparities candidate disparities (docs/ALGORITHM.md §6).
#pragma once
#include <opencv2/core.hpp>

#include "ielas/config.hpp"
#include "ielas/types.hpp"

namespace ielas {

// From the filtered support lattice (support_filtered_L): each point (u, v, d) marks d-1..d+1 (clipped to
// 0..dispMax) in cell (floor(v/gridSize), floor(x/gridSize)) with x = u (left view) or u - d (right view);
// a 3x3 dilation over in-grid cells; then at most storedDisparities survive per cell (cfg.gridKeep),
// listed ascending, -1 = unused slot.
Grid buildGrid(const cv::Mat& filtered, int W, int H, View view, const Config& cfg);

// Cells (rows, cols, storedDisparities) as an int16 array for grid_L.npy / grid_R.npy.
std::vector<int> gridShape(const Grid& g);

}  // namespace ielas
