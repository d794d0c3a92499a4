// `match --mode elas`: a faithful float reimplementation of libelas (Geiger et al.), full resolution.
#pragma once
#include <opencv2/core.hpp>
#include "ielas/config.hpp"

namespace ielas {

// Left disparity map of a rectified 8-bit grey pair: CV_32F, H x W, negative = invalid.
cv::Mat elasMatch(const cv::Mat& left8, const cv::Mat& right8, const Config& cfg);

}  // namespace ielas
