// Stage `descriptor`: Sobel gradients and the 16-byte ELAS descriptor at every pixel (docs/ALGORITHM.md §1-2).
#pragma once
#include <cstdint>

#include <opencv2/core.hpp>

#include "ielas/config.hpp"

namespace ielas {

constexpr int kDescriptorBytes = 16;

// du/dv (CV_8U, H x W) of docs/ALGORITHM.md (descriptor, step 1). Defined for 1 <= x <= W-2, 1 <= y <= H-2;
// the frame border is 128 (a zero gradient) and is never read by the descriptor.
void sobel(const cv::Mat& image8, cv::Mat& du, cv::Mat& dv);

// Descriptor image: H x W, CV_8UC(16). Window radius r = windowSize / 2; pixels closer than r + 1 to the
// border are all-zero.
cv::Mat computeDescriptor(const cv::Mat& image8, const Config& cfg);

// texture = sum_k |byte_k - 128|
int descriptorTexture(const uint8_t* desc);

// Sum of absolute differences of two 16-byte descriptors.
int sad16(const uint8_t* a, const uint8_t* b);

}  // namespace ielas
