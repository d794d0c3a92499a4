// Input images and disparity outputs.
#include "ielas/image_io.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace ielas {

cv::Mat loadGray8(const std::string& path) {
  std::ifstream probe(path, std::ios::binary);
  if (!probe.good()) throw std::runtime_error("cannot read image " + path);
  cv::Mat raw;
  try {
    raw = cv::imread(path, cv::IMREAD_UNCHANGED);  // unchanged: keeps 16-bit images 16-bit so they can be rejected
  } catch (const cv::Exception&) {
    raw.release();
  }
  if (raw.empty()) throw std::runtime_error("cannot read image " + path + " (not a PNG/PGM image)");
  if (raw.depth() != CV_8U) throw std::runtime_error("image " + path + " is deeper than 8 bits (8-bit grey or colour expected)");
  cv::Mat grey;
  switch (raw.channels()) {
    case 1: grey = raw; break;
    case 3: cv::cvtColor(raw, grey, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(raw, grey, cv::COLOR_BGRA2GRAY); break;
    default: throw std::runtime_error("image " + path + " has " + std::to_string(raw.channels()) + " channels (1, 3 or 4 expected)");
  }
  return grey.isContinuous() ? grey : grey.clone();
}

void checkPairSize(const cv::Mat& left, const cv::Mat& right, int maxWidth, int maxHeight, const std::string& what) {
  if (left.size() != right.size())
    throw std::runtime_error("left/right size mismatch: " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                             " vs " + std::to_string(right.cols) + "x" + std::to_string(right.rows));
  if (left.cols < 32 || left.rows < 16 || left.cols > maxWidth || left.rows > maxHeight)
    throw std::runtime_error("image size " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                             " is outside 32x16.." + std::to_string(maxWidth) + "x" + std::to_string(maxHeight) + " (" + what + ")");
}

void writePfm(const std::string& path, const cv::Mat& disparity) {
  CV_Assert(disparity.type() == CV_32F);
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << "Pf\n" << disparity.cols << " " << disparity.rows << "\n-1.0\n";  // negative scale = little-endian
  for (int y = disparity.rows - 1; y >= 0; --y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      float v = row[x] < 0.0f ? -1.0f : row[x];
      uint32_t bits;
      std::memcpy(&bits, &v, 4);
      unsigned char le[4] = {static_cast<unsigned char>(bits), static_cast<unsigned char>(bits >> 8),
                             static_cast<unsigned char>(bits >> 16), static_cast<unsigned char>(bits >> 24)};
      out.write(reinterpret_cast<const char*>(le), 4);
    }
  }
  if (!out) throw std::runtime_error("cannot write " + path);
}

void writeKittiPng(const std::string& path, const cv::Mat& disparity) {
  CV_Assert(disparity.type() == CV_32F);
  cv::Mat out(disparity.size(), CV_16U);
  for (int y = 0; y < disparity.rows; ++y)
    for (int x = 0; x < disparity.cols; ++x) {
      float d = disparity.at<float>(y, x);
      // 0 means invalid in KITTI, so a valid 0 disparity becomes the smallest valid code 1.
      double v = d < 0.0f ? 0.0 : std::max(1.0, std::min(65535.0, std::round(d * 256.0)));
      out.at<uint16_t>(y, x) = static_cast<uint16_t>(v);
    }
  if (!cv::imwrite(path, out)) throw std::runtime_error("cannot write " + path);
}

cv::Mat readPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (magic != "Pf" || w <= 0 || h <= 0 || scale == 0) throw std::runtime_error("not a grey PFM file: " + path);
  cv::Mat d(h, w, CV_32F);
  for (int y = h - 1; y >= 0; --y)
    for (int x = 0; x < w; ++x) {
      unsigned char b[4];
      if (!in.read(reinterpret_cast<char*>(b), 4)) throw std::runtime_error("truncated PFM file: " + path);
      uint32_t bits = scale < 0 ? (b[0] | b[1] << 8 | b[2] << 16 | static_cast<uint32_t>(b[3]) << 24)
                                : (b[3] | b[2] << 8 | b[1] << 16 | static_cast<uint32_t>(b[0]) << 24);
      float v;
      std::memcpy(&v, &bits, 4);
      d.at<float>(y, x) = v;
    }
  return d;
}

}  // namespace ielas
