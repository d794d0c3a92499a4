// NumPy .npy files, version 1.0, little-endian, C order, dtypes |u1 <i2 <u2 <i4 (docs/interfaces.md §3).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace ielas {

struct NpyArray {
  std::string descr;               // "|u1", "<i2", "<u2" or "<i4"
  std::vector<int> shape;          // 2 to 4 dimensions, rows first
  std::vector<unsigned char> data; // raw little-endian element bytes, C order

  size_t count() const;
  int itemSize() const;
  int64_t value(size_t flatIndex) const;  // element as a signed integer
};

int npyItemSize(const std::string& descr);  // throws on an unsupported dtype

// The 10-byte preamble + header (padded with spaces and '\n' to a multiple of 64 bytes).
std::string npyHeader(const std::string& descr, const std::vector<int>& shape);

void writeNpy(const std::string& path, const std::string& descr, const std::vector<int>& shape, const void* data);
NpyArray readNpy(const std::string& path);  // throws std::runtime_error with a one-line message

// Convenience writers: a 2-D Mat (CV_8U/16S/16U/32S) or a multi-channel CV_8UC(n) as (rows, cols, n).
void writeNpyMat(const std::string& path, const cv::Mat& m);

}  // namespace ielas
