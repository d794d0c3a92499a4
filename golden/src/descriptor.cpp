// Stage `descriptor`: Sobel du/dv and the ELAS descriptor layout generalised to window radius r.
#include "ielas/descriptor.hpp"

#include <cstdlib>
#include <stdexcept>
#include <vector>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

namespace ielas {

namespace {
inline uint8_t satU8(int v) { return static_cast<uint8_t>(v < 0 ? 0 : (v > 255 ? 255 : v)); }
}  // namespace

void sobel(const cv::Mat& image8, cv::Mat& du, cv::Mat& dv) {
  CV_Assert(image8.type() == CV_8U);
  const int W = image8.cols, H = image8.rows;
  du.create(H, W, CV_8U);
  dv.create(H, W, CV_8U);
  du.setTo(128);
  dv.setTo(128);
  std::vector<int> s(W), t(W);
  for (int y = 1; y <= H - 2; ++y) {
    const uint8_t* up = image8.ptr<uint8_t>(y - 1);
    const uint8_t* mid = image8.ptr<uint8_t>(y);
    const uint8_t* down = image8.ptr<uint8_t>(y + 1);
    for (int x = 0; x < W; ++x) {
      s[x] = up[x] + 2 * mid[x] + down[x];  // vertical smoothing
      t[x] = up[x] - down[x];               // vertical difference (top minus bottom)
    }
    uint8_t* duRow = du.ptr<uint8_t>(y);
    uint8_t* dvRow = dv.ptr<uint8_t>(y);
    for (int x = 1; x <= W - 2; ++x) {
      // >> on a negative int is an arithmetic shift (floor division by 4) with g++, as in libelas's SSE code.
      duRow[x] = satU8(((s[x - 1] - s[x + 1]) >> 2) + 128);
      dvRow[x] = satU8(((t[x - 1] + 2 * t[x] + t[x + 1]) >> 2) + 128);
    }
  }
}

cv::Mat computeDescriptor(const cv::Mat& image8, const Config& cfg) {
  const int W = image8.cols, H = image8.rows;
  const int r = cfg.windowRadius();
  if (r < 1 || r > 3) throw std::runtime_error("descriptor: windowSize must be 3, 5 or 7");
  const int m = r + 1;  // descriptor margin: the farthest gradient read is r away, and gradients need 1 more
  cv::Mat du, dv;
  sobel(image8, du, dv);
  cv::Mat desc = cv::Mat::zeros(H, W, CV_8UC(kDescriptorBytes));
  for (int y = m; y <= H - 1 - m; ++y) {
    const uint8_t* duUp2 = du.ptr<uint8_t>(y - r);
    const uint8_t* duUp = du.ptr<uint8_t>(y - 1);
    const uint8_t* duMid = du.ptr<uint8_t>(y);
    const uint8_t* duDown = du.ptr<uint8_t>(y + 1);
    const uint8_t* duDown2 = du.ptr<uint8_t>(y + r);
    const uint8_t* dvUp = dv.ptr<uint8_t>(y - 1);
    const uint8_t* dvMid = dv.ptr<uint8_t>(y);
    const uint8_t* dvDown = dv.ptr<uint8_t>(y + 1);
    uint8_t* out = desc.ptr<uint8_t>(y);
    for (int x = m; x <= W - 1 - m; ++x) {
      uint8_t* d = out + static_cast<size_t>(x) * kDescriptorBytes;
      d[0] = duUp2[x];
      d[1] = duUp[x - r];
      d[2] = duUp[x];
      d[3] = duUp[x + r];
      d[4] = duMid[x - 1];
      d[5] = duMid[x];
      d[6] = duMid[x];  // the centre twice: weight 2 in the SAD, as ELAS
      d[7] = duMid[x + 1];
      d[8] = duDown[x - r];
      d[9] = duDown[x];
      d[10] = duDown[x + r];
      d[11] = duDown2[x];
      d[12] = dvUp[x];
      d[13] = dvMid[x - 1];
      d[14] = dvMid[x + 1];
      d[15] = dvDown[x];
    }
  }
  return desc;
}

int descriptorTexture(const uint8_t* desc) {
  int sum = 0;
  for (int k = 0; k < kDescriptorBytes; ++k) sum += std::abs(desc[k] - 128);
  return sum;
}

int sad16(const uint8_t* a, const uint8_t* b) {
#ifdef __SSE2__
  __m128i s = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a)),
                           _mm_loadu_si128(reinterpret_cast<const __m128i*>(b)));
  return _mm_cvtsi128_si32(s) + _mm_extract_epi16(s, 4);
#else
  int sum = 0;
  for (int k = 0; k < kDescriptorBytes; ++k) sum += std::abs(a[k] - b[k]);
  return sum;
#endif
}

}  // namespace ielas
