// Stage `post`: bounded small-segment removal, gap interpolation (rows; columns within a bounded window),
// then adaptive mean (robotics) and/or median (middlebury). Rules and look-ahead: docs/ALGORITHM.md "## Late stages".
#pragma once
#include <opencv2/core.hpp>
#include "ielas/config.hpp"

namespace ielas {

// lrL: CV_16S H x W integer disparity, -1 invalid. Returns CV_16S H x W, disparity * 16, -1 invalid.
cv::Mat postprocess(const cv::Mat& lrL, const Config& cfg);

// The steps, exposed for the unit tests. All maps are CV_16S, -1 invalid, modified in place.
// d: integer disparities. A 4-connected segment (neighbours valid, |difference| <= simThreshold) is removed when
// it has fewer than minSize pixels, except, for a pixel in row v, when the segment reaches row v + windowRows - 1
// and that row is not the last image row (the streaming window cannot see its end yet).
void removeSmallSegments(cv::Mat& d, int simThreshold, int minSize, int windowRows);
// d16: disparity * 16. Row runs of <= rowGap invalid pixels between two valid ones, then column runs of
// <= colGap; extrapolate = libelas add_corners (row ends up to rowGap pixels, column end runs of <= colGap).
void interpolateGaps(cv::Mat& d16, int rowGap, int colGap, bool extrapolate);
// d16: 8-tap (offsets -4..+3) separable mean with weights 4 / 2 / 0 for |delta| < 2 / < 8 / >= 8 px.
void adaptiveMean(cv::Mat& d16);
// d16: 7-tap separable median (4th smallest), invalid taps take part as -1.
void median7(cv::Mat& d16);

}  // namespace ielas
