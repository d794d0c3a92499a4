// Arrays passed between golden stages. Shapes and invalid codes match the .npy dumps (docs/interfaces.md §3).
#pragma once
#include <cstdint>
#include <vector>
#include <opencv2/core.hpp>

namespace ielas {

// Descriptors: cv::Mat of H x W, type CV_8UC(descriptorBytes).
// Lattice maps (support, filtered, filled lattice): cv::Mat CV_16S of latticeRows x latticeCols, -1 = none.
//   Node (i, j) sits at pixel (Config::latticeCoord(i, W), Config::latticeCoord(j, H)).
// Disparity maps (dense, lrcheck): cv::Mat CV_16S of H x W, -1 = invalid.
// Output disparity (post, top): cv::Mat CV_16S of H x W, value = disparity * 16, -1 = invalid.

// Grid vector: per grid cell up to `slots` candidate disparities, ascending, -1 = unused slot.
struct Grid {
  int rows = 0, cols = 0, slots = 0;
  std::vector<int16_t> d;  // rows * cols * slots, C order
  int16_t& at(int r, int c, int k) { return d[(static_cast<size_t>(r) * cols + c) * slots + k]; }
  int16_t at(int r, int c, int k) const { return d[(static_cast<size_t>(r) * cols + c) * slots + k]; }
};

enum class View { Left, Right };

}  // namespace ielas
