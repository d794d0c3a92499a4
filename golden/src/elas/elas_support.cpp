// libelas support matching: 4-corner descriptor window, best/second-best ratio test, L/R check
// (docs/ALGORITHM.md, elas mode).
#include <algorithm>
#include <cstdlib>

#include "ielas/descriptor.hpp"
#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

namespace {
// Corners of the support window, (+-2, +-2) around the point; the centre descriptor is not part of the cost.
constexpr int kCornerStep = 2;
}  // namespace

int matchSupportPoint(const cv::Mat& descL, const cv::Mat& descR, int u, int v, View ref, const Config& cfg) {
  const int width = descL.cols, height = descL.rows;
  const int margin = cfg.supportMargin;  // window_size 3 + step 2 in libelas
  if (u < margin || u > width - margin - 1 || v < margin || v > height - margin - 1) return -1;
  const cv::Mat& dRef = ref == View::Left ? descL : descR;
  const cv::Mat& dTgt = ref == View::Left ? descR : descL;
  const uint8_t* centre = dRef.ptr<uint8_t>(v) + 16 * u;
  if (textureInline(centre) < cfg.supportTexture) return -1;

  const int dLo = 0;
  const int dHi = ref == View::Left ? std::min(cfg.dispMax, u - margin) : std::min(cfg.dispMax, width - u - margin);
  if (dHi - dLo < cfg.supportMinRange) return -1;

  const uint8_t* refRowTop = dRef.ptr<uint8_t>(v - kCornerStep);
  const uint8_t* refRowBot = dRef.ptr<uint8_t>(v + kCornerStep);
  const uint8_t* tgtRowTop = dTgt.ptr<uint8_t>(v - kCornerStep);
  const uint8_t* tgtRowBot = dTgt.ptr<uint8_t>(v + kCornerStep);
  const uint8_t* r1 = refRowTop + 16 * (u - kCornerStep);
  const uint8_t* r2 = refRowTop + 16 * (u + kCornerStep);
  const uint8_t* r3 = refRowBot + 16 * (u - kCornerStep);
  const uint8_t* r4 = refRowBot + 16 * (u + kCornerStep);

  // Strict "<" keeps the lower d on ties; no exclusion around the best, as in libelas.
  int bestE = 32767, bestD = -1, secondE = 32767, secondD = -1;
  for (int d = dLo; d <= dHi; ++d) {
    const int uw = ref == View::Left ? u - d : u + d;
    const int cost = sad16Inline(r1, tgtRowTop + 16 * (uw - kCornerStep)) + sad16Inline(r2, tgtRowTop + 16 * (uw + kCornerStep)) +
                     sad16Inline(r3, tgtRowBot + 16 * (uw - kCornerStep)) + sad16Inline(r4, tgtRowBot + 16 * (uw + kCornerStep));
    if (cost < bestE) {
      secondE = bestE;
      secondD = bestD;
      bestE = cost;
      bestD = d;
    } else if (cost < secondE) {
      secondE = cost;
      secondD = d;
    }
  }
  // libelas compares in float with support_threshold a float (0.85f / 0.95f).
  const float threshold = static_cast<float>(cfg.supportThresholdPercent) / 100.0f;
  if (bestD >= 0 && secondD >= 0 && static_cast<float>(bestE) < threshold * static_cast<float>(secondE)) return bestD;
  return -1;
}

cv::Mat supportLattice(const cv::Mat& descL, const cv::Mat& descR, const Config& cfg) {
  const int width = descL.cols, height = descL.rows, step = cfg.candidateStep;
  const int cols = (width + step - 1) / step, rows = (height + step - 1) / step;
  cv::Mat lattice(rows, cols, CV_16S, cv::Scalar(0));  // row 0 / column 0 stay 0: libelas quirk
  for (int i = 1; i < cols; ++i) {
    const int u = i * step;
    for (int j = 1; j < rows; ++j) {
      const int v = j * step;
      int16_t value = -1;
      const int d = matchSupportPoint(descL, descR, u, v, View::Left, cfg);
      if (d >= 0) {
        const int d2 = matchSupportPoint(descL, descR, u - d, v, View::Right, cfg);
        if (d2 >= 0 && std::abs(d - d2) <= cfg.lrThreshold) value = static_cast<int16_t>(d);
      }
      lattice.at<int16_t>(j, i) = value;
    }
  }
  return lattice;
}

}  // namespace elas
}  // namespace ielas
