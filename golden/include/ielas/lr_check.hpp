// Stage `lrcheck`: dense left/right consistency (docs/ALGORITHM.md, lrcheck), per row.
#pragma once
#include <opencv2/core.hpp>
#include "ielas/config.hpp"

namespace ielas {

// denseL/denseR: CV_16S H x W, -1 invalid. outL/outR: CV_16S H x W, -1 invalid.
void lrCheck(const cv::Mat& denseL, const cv::Mat& denseR, cv::Mat& outL, cv::Mat& outR, const Config& cfg);

}  // namespace ielas
