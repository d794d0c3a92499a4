// Stage `filter`: snapshot inconsistency filter of the support lattice (docs/ALGORITHM.md §4).
#pragma once
#include <opencv2/core.hpp>

#include "ielas/config.hpp"

namespace ielas {

// support_filtered_L: a node survives if at least inconMinSupport nodes (itself included) within
// +-inconWindowSize lattice steps hold a support with |difference| <= inconThreshold. Counts read the unfiltered
// map (no in-place removal); there is no redundancy removal.
cv::Mat filterSupport(const cv::Mat& support, const Config& cfg);

}  // namespace ielas
