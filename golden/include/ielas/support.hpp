// Stage `support`: sparse support points on the candidate lattice with the ratio test and the L/R check
// (docs/ALGORITHM.md §3).
#pragma once
#include <opencv2/core.hpp>

#include "ielas/config.hpp"
#include "ielas/types.hpp"

namespace ielas {

// match(ref, u, v): the disparity of pixel (u,v) of the reference view `ref` (left: target column u - d;
// right: u + d), or -1 (margin, texture, range or ratio test failed).
int supportMatch(const cv::Mat& descL, const cv::Mat& descR, int u, int v, View ref, const Config& cfg);

// support_L: CV_16S, latticeCount(H) x latticeCount(W); -1 = no support. Row 0, column 0 and the extra last
// row/column are never supports.
cv::Mat supportLattice(const cv::Mat& descL, const cv::Mat& descR, const Config& cfg);

// True for the lattice nodes that can hold a support point: i >= 1 and i * step < pixels.
bool latticeNodeMatchable(int index, int pixels, const Config& cfg);

}  // namespace ielas
