// Stage `dense`: per-pixel disparity from plane prior + grid candidates (libelas find_match, integer).
#pragma once
#include <opencv2/core.hpp>
#include "ielas/config.hpp"
#include "ielas/planes.hpp"
#include "ielas/types.hpp"

namespace ielas {

// descL/descR: H x W CV_8UC(16). grid: grid_L for View::Left, grid_R for View::Right.
// Returns CV_16S H x W disparity of `view`, -1 invalid.
cv::Mat denseMatch(const cv::Mat& descL, const cv::Mat& descR, const Planes& planes, const Grid& grid, View view,
                   const Config& cfg);

}  // namespace ielas
