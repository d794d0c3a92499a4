// libelas post-processing: small-segment removal, gap interpolation, adaptive mean, median
// (docs/ALGORITHM.md, elas mode).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

void removeSmallSegments(cv::Mat& disp, const Config& cfg) {
  const int width = disp.cols, height = disp.rows;
  std::vector<uint8_t> done(static_cast<size_t>(width) * height, 0);
  std::vector<int> listU(static_cast<size_t>(width) * height), listV(listU.size());
  const float similarity = static_cast<float>(cfg.speckleSimThreshold);
  const int du[4] = {-1, 1, 0, 0}, dv[4] = {0, 0, -1, 1};  // left, right, up, down
  for (int u = 0; u < width; ++u)
    for (int v = 0; v < height; ++v) {
      if (done[static_cast<size_t>(v) * width + u]) continue;
      // Breadth-first growth; invalid seeds become one-pixel segments. Similarity chains through the list.
      listU[0] = u;
      listV[0] = v;
      int count = 1;
      for (int current = 0; current < count; ++current) {
        const int cu = listU[current], cv_ = listV[current];
        const float dCurrent = disp.at<float>(cv_, cu);
        for (int k = 0; k < 4; ++k) {
          const int nu = cu + du[k], nv = cv_ + dv[k];
          if (nu < 0 || nv < 0 || nu >= width || nv >= height) continue;
          uint8_t& neighbourDone = done[static_cast<size_t>(nv) * width + nu];
          const float dNeighbour = disp.at<float>(nv, nu);
          if (!neighbourDone && dNeighbour >= 0 && std::fabs(dCurrent - dNeighbour) <= similarity) {
            listU[count] = nu;
            listV[count] = nv;
            ++count;
            neighbourDone = 1;
          }
        }
        done[static_cast<size_t>(cv_) * width + cu] = 1;
      }
      if (count < cfg.speckleSize)
        for (int k = 0; k < count; ++k) disp.at<float>(listV[k], listU[k]) = kInvalid;
    }
}

namespace {

constexpr float kDiscontinuity = 3.0f;

// One line of the gap interpolation: `at(k)` addresses element k of a row or column of length n.
template <typename At>
void interpolateLine(At at, int n, int gapWidth, bool extrapolate) {
  int count = 0;
  for (int k = 0; k < n; ++k) {
    if (at(k) >= 0) {
      if (count >= 1 && count <= gapWidth) {
        const int first = k - count, last = k - 1;
        if (first > 0 && last < n - 1) {  // gaps touching the border are not filled
          const float d1 = at(first - 1), d2 = at(last + 1);
          const float value = std::fabs(d1 - d2) < kDiscontinuity ? (d1 + d2) / 2 : std::min(d1, d2);
          for (int i = first; i <= last; ++i) at(i) = value;
        }
      }
      count = 0;
    } else {
      ++count;
    }
  }
  if (!extrapolate) return;
  for (int k = 0; k < n; ++k)
    if (at(k) >= 0) {
      for (int i = std::max(k - gapWidth, 0); i < k; ++i) at(i) = at(k);
      break;
    }
  for (int k = n - 1; k >= 0; --k)
    if (at(k) >= 0) {
      for (int i = k; i <= std::min(k + gapWidth, n - 1); ++i) at(i) = at(k);
      break;
    }
}

}  // namespace

void gapInterpolation(cv::Mat& disp, const Config& cfg) {
  const int width = disp.cols, height = disp.rows, gap = cfg.ipolGapWidth;
  for (int v = 0; v < height; ++v) {
    float* row = disp.ptr<float>(v);
    interpolateLine([row](int k) -> float& { return row[k]; }, width, gap, cfg.addCorners);
  }
  for (int u = 0; u < width; ++u)
    interpolateLine([&disp, u](int k) -> float& { return disp.at<float>(k, u); }, height, gap, cfg.addCorners);
}

float adaptiveMeanWeight(float delta) {
  // QUIRK: libelas's "abs" ANDs with the bits of the float 2147483647.0f (0x4F000000), not with 0x7FFFFFFF.
  uint32_t bits;
  std::memcpy(&bits, &delta, sizeof bits);
  bits &= 0x4F000000u;
  float masked;
  std::memcpy(&masked, &bits, sizeof masked);
  return std::max(0.0f, 4.0f - masked);
}

namespace {

// One 8-tap pass over a line: ring slot k holds element (index mod 8); output index p = k - 3 for k = 7..n-1.
// Float order as libelas's SSE code: lane j adds slots j and j+4, then ((L0+L1)+L2)+L3, then one division.
template <typename In, typename Out>
void adaptiveMeanLine(In in, Out out, int n) {
  float ring[8];
  for (int k = 0; k < 7 && k < n; ++k) ring[k] = in(k);
  for (int k = 7; k < n; ++k) {
    const float centre = in(k - 3);
    ring[k % 8] = in(k);
    float weight[4], factor[4];
    for (int j = 0; j < 4; ++j) {
      const float w1 = adaptiveMeanWeight(ring[j] - centre), w2 = adaptiveMeanWeight(ring[j + 4] - centre);
      const float f1 = ring[j] * w1, f2 = ring[j + 4] * w2;
      weight[j] = w1 + w2;
      factor[j] = f1 + f2;
    }
    const float weightSum = weight[0] + weight[1] + weight[2] + weight[3];
    const float factorSum = factor[0] + factor[1] + factor[2] + factor[3];
    if (weightSum > 0) {
      const float d = factorSum / weightSum;
      if (d >= 0) out(k - 3) = d;
    }
  }
}

}  // namespace

void adaptiveMean(cv::Mat& disp) {
  const int width = disp.cols, height = disp.rows;
  // Invalid pixels become -10 so that they get weight 0 next to valid ones. libelas leaves the scratch map
  // uninitialised where the horizontal pass does not write; here it starts as a copy (see ALGORITHM.md).
  cv::Mat input = disp.clone();
  input.setTo(kInvalid, disp < 0);
  cv::Mat scratch = input.clone();
  for (int v = 3; v < height - 3; ++v) {
    const float* in = input.ptr<float>(v);
    float* out = scratch.ptr<float>(v);
    adaptiveMeanLine([in](int k) { return in[k]; }, [out](int k) -> float& { return out[k]; }, width);
  }
  // The vertical pass runs on the transposed maps so that it walks memory row by row.
  cv::Mat scratchT, dispT;
  cv::transpose(scratch, scratchT);
  cv::transpose(disp, dispT);
  for (int u = 3; u < width - 3; ++u) {
    const float* in = scratchT.ptr<float>(u);
    float* out = dispT.ptr<float>(u);
    adaptiveMeanLine([in](int k) { return in[k]; }, [out](int k) -> float& { return out[k]; }, height);
  }
  cv::transpose(dispT, disp);
}

void median(cv::Mat& disp) {
  constexpr int r = 3;  // 7 taps, the 4th smallest; invalid taps count as values
  const int width = disp.cols, height = disp.rows;
  cv::Mat horizontal(height, width, CV_32F, cv::Scalar(0));  // zero rows 0-2 / H-3.. leak in: libelas quirk
  float taps[2 * r + 1];
  for (int u = r; u < width - r; ++u)
    for (int v = r; v < height - r; ++v) {
      const float centre = disp.at<float>(v, u);
      if (centre >= 0) {
        for (int k = -r; k <= r; ++k) taps[k + r] = disp.at<float>(v, u + k);
        std::nth_element(taps, taps + r, taps + 2 * r + 1);
        horizontal.at<float>(v, u) = taps[r];
      } else {
        horizontal.at<float>(v, u) = centre;
      }
    }
  for (int u = r; u < width - r; ++u)
    for (int v = r; v < height - r; ++v) {
      if (disp.at<float>(v, u) < 0) continue;
      for (int k = -r; k <= r; ++k) taps[k + r] = horizontal.at<float>(v + k, u);
      std::nth_element(taps, taps + r, taps + 2 * r + 1);
      disp.at<float>(v, u) = taps[r];
    }
}

}  // namespace elas
}  // namespace ielas
