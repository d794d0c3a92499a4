// Stage `post`: bounded speckle removal, gap interpolation (rows, bounded columns), median or adaptive mean.
#pragma once
#include <opencv2/core.hpp>
#include "ielas/config.hpp"

namespace ielas {

// lrL: CV_16S H x W disparity, -1 invalid. Returns CV_16S H x W, disparity * 16, -1 invalid.
cv::Mat postprocess(const cv::Mat& lrL, const Config& cfg);

}  // namespace ielas
