// Sobel and descriptor against hand-computed values (docs/ALGORITHM.md, descriptor steps 1-2).
#include <cstdint>

#include "check.hpp"
#include "ielas/descriptor.hpp"

using namespace ielas;

namespace {

Config configWithWindow(int windowSize) {
  Config c;
  c.windowSize = windowSize;
  return c;
}

void testStepEdge() {
  // Vertical step 0 -> 100 between columns 2 and 3: S = 4 I, so du = I(x-1) - I(x+1) + 128, dv = 128.
  cv::Mat img(5, 6, CV_8U, cv::Scalar(0));
  img.colRange(3, 6).setTo(100);
  cv::Mat du, dv;
  sobel(img, du, dv);
  for (int y = 1; y <= 3; ++y) {
    CHECK_EQ(du.at<uint8_t>(y, 1), 128);
    CHECK_EQ(du.at<uint8_t>(y, 2), 28);
    CHECK_EQ(du.at<uint8_t>(y, 3), 28);
    CHECK_EQ(du.at<uint8_t>(y, 4), 128);
    for (int x = 1; x <= 4; ++x) CHECK_EQ(dv.at<uint8_t>(y, x), 128);
  }
}

void testSaturation() {
  // 0 -> 255: -255 + 128 clamps to 0; 255 -> 0: 255 + 128 clamps to 255. Horizontal edge for dv the same way.
  cv::Mat rising(5, 6, CV_8U, cv::Scalar(0));
  rising.colRange(3, 6).setTo(255);
  cv::Mat du, dv;
  sobel(rising, du, dv);
  CHECK_EQ(du.at<uint8_t>(2, 2), 0);
  CHECK_EQ(du.at<uint8_t>(2, 3), 0);
  cv::Mat falling = 255 - rising;
  sobel(falling, du, dv);
  CHECK_EQ(du.at<uint8_t>(2, 2), 255);
  cv::Mat bottom(6, 5, CV_8U, cv::Scalar(0));
  bottom.rowRange(3, 6).setTo(255);  // top minus bottom = -255 -> (-255*4)>>2 = -255 -> 0
  sobel(bottom, du, dv);
  CHECK_EQ(dv.at<uint8_t>(2, 2), 0);
  CHECK_EQ(dv.at<uint8_t>(3, 2), 0);
  CHECK_EQ(dv.at<uint8_t>(1, 2), 128);
  CHECK_EQ(du.at<uint8_t>(2, 2), 128);
}

void testRampAndFloor() {
  // Horizontal ramp I = 10 x: S = 40 x, du = (-80 >> 2) + 128 = 108.
  cv::Mat ramp(4, 8, CV_8U);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) ramp.at<uint8_t>(y, x) = static_cast<uint8_t>(10 * x);
  cv::Mat du, dv;
  sobel(ramp, du, dv);
  for (int x = 1; x <= 6; ++x) {
    CHECK_EQ(du.at<uint8_t>(1, x), 108);
    CHECK_EQ(dv.at<uint8_t>(2, x), 128);
  }
  // A single 1 at (2,2): du(2,1) = (0 - 2) >> 2 = -1 (floor, not 0) -> 127; du(2,3) = 2 >> 2 = 0 -> 128;
  // du(1,1) = (0 - 1) >> 2 = -1 -> 127; dv(1,2) = (2 * (0 - 1)) >> 2 = -1 -> 127; dv(3,2) = 2 >> 2 -> 128.
  cv::Mat dot(5, 5, CV_8U, cv::Scalar(0));
  dot.at<uint8_t>(2, 2) = 1;
  sobel(dot, du, dv);
  CHECK_EQ(du.at<uint8_t>(2, 1), 127);
  CHECK_EQ(du.at<uint8_t>(2, 3), 128);
  CHECK_EQ(du.at<uint8_t>(1, 1), 127);
  CHECK_EQ(dv.at<uint8_t>(1, 2), 127);
  CHECK_EQ(dv.at<uint8_t>(3, 2), 128);
}

// I = x^2 + y^2 + x y gives exactly du = 128 - 4x - 2y and dv = 128 - 2x - 4y (all sums are multiples of 4).
int duAt(int x, int y) { return 128 - 4 * x - 2 * y; }
int dvAt(int x, int y) { return 128 - 2 * x - 4 * y; }

void testLayout(int windowSize) {
  const int W = 10, H = 10, r = windowSize / 2, m = r + 1;
  cv::Mat img(H, W, CV_8U);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) img.at<uint8_t>(y, x) = static_cast<uint8_t>(x * x + y * y + x * y);
  cv::Mat du, dv;
  sobel(img, du, dv);
  CHECK_EQ(du.at<uint8_t>(4, 5), duAt(5, 4));  // the closed form itself, checked once through sobel()
  CHECK_EQ(dv.at<uint8_t>(4, 5), dvAt(5, 4));
  cv::Mat desc = computeDescriptor(img, configWithWindow(windowSize));
  CHECK_EQ(desc.rows, H);
  CHECK_EQ(desc.cols, W);
  CHECK_EQ(desc.channels(), 16);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const uint8_t* d = desc.ptr<uint8_t>(y) + x * 16;
      const bool inside = x >= m && x <= W - 1 - m && y >= m && y <= H - 1 - m;
      if (!inside) {
        for (int k = 0; k < 16; ++k) CHECK_EQ(d[k], 0);
        continue;
      }
      const int expected[16] = {duAt(x, y - r),     duAt(x - r, y - 1), duAt(x, y - 1),     duAt(x + r, y - 1),
                                duAt(x - 1, y),     duAt(x, y),         duAt(x, y),         duAt(x + 1, y),
                                duAt(x - r, y + 1), duAt(x, y + 1),     duAt(x + r, y + 1), duAt(x, y + r),
                                dvAt(x, y - 1),     dvAt(x - 1, y),     dvAt(x + 1, y),     dvAt(x, y + 1)};
      for (int k = 0; k < 16; ++k) CHECK_EQ(static_cast<int>(d[k]), expected[k]);
      int texture = 0;
      for (int k = 0; k < 16; ++k) texture += expected[k] > 128 ? expected[k] - 128 : 128 - expected[k];
      CHECK_EQ(descriptorTexture(d), texture);
    }
}

void testTextureAndSad() {
  uint8_t flat[16], zero[16] = {0}, mixed[16];
  for (int k = 0; k < 16; ++k) {
    flat[k] = 128;
    mixed[k] = static_cast<uint8_t>(k % 2 ? 138 : 120);  // |10| and |8|: 8*10 + 8*8 = 144
  }
  CHECK_EQ(descriptorTexture(flat), 0);
  CHECK_EQ(descriptorTexture(zero), 2048);
  CHECK_EQ(descriptorTexture(mixed), 144);
  CHECK_EQ(sad16(flat, zero), 2048);
  CHECK_EQ(sad16(flat, mixed), 144);
  CHECK_EQ(sad16(mixed, mixed), 0);
  uint8_t high[16], low[16];
  for (int k = 0; k < 16; ++k) {
    high[k] = 255;
    low[k] = 0;
  }
  CHECK_EQ(sad16(high, low), 4080);
}

}  // namespace

int main() {
  testStepEdge();
  testSaturation();
  testRampAndFloor();
  for (int w : {3, 5, 7}) testLayout(w);
  testTextureAndSad();
  return testExitCode("test_descriptor");
}
