// Input images (PNG/PGM, 8-bit, colour converted to grey) and disparity outputs (PFM, KITTI PNG).
#pragma once
#include <string>

#include <opencv2/core.hpp>

#include "ielas/config.hpp"

namespace ielas {

// Reads a PNG or PGM image with 8 bits per sample as CV_8U grey (colour via COLOR_BGR2GRAY). Other bit depths
// (1, 2, 4, 16) are rejected, not converted. The header is checked before decoding (a PNG must reach its IEND
// chunk, a binary PGM must hold all its pixels) and the decoders print nothing: every problem is one
// std::runtime_error line such as "image L.png: truncated or corrupt PNG (no IEND chunk)".
cv::Mat loadGray8(const std::string& path);

// Throws unless both images have the same size and it lies in 32x16 .. maxWidth x maxHeight.
void checkPairSize(const cv::Mat& left, const cv::Mat& right, int maxWidth, int maxHeight, const std::string& what);

// PFM: "Pf", "W H", scale -1.0 (little-endian), float32 rows bottom to top. `disparity` is CV_32F, negative = invalid.
void writePfm(const std::string& path, const cv::Mat& disparity);
// KITTI PNG: uint16, value = round(disparity * 256), 0 = invalid. `disparity` is CV_32F, negative = invalid.
void writeKittiPng(const std::string& path, const cv::Mat& disparity);
// Reads a PFM written by writePfm (grey "Pf", either endianness) back into CV_32F, top row first.
cv::Mat readPfm(const std::string& path);

}  // namespace ielas
