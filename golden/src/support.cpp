// Stage `support`: ratio-tested support matches on the lattice, then the left/right check.
#include "ielas/support.hpp"

#include <algorithm>
#include <climits>
#include <cstdlib>

#include "ielas/descriptor.hpp"

namespace ielas {

bool latticeNodeMatchable(int index, int pixels, const Config& cfg) {
  return index >= 1 && index * cfg.candidateStep < pixels;
}

int supportMatch(const cv::Mat& descL, const cv::Mat& descR, int u, int v, View ref, const Config& cfg) {
  const int W = descL.cols, H = descL.rows;
  const int r = cfg.windowRadius();
  const int M = 2 * r + 1;  // corners reach r, their descriptors need r + 1 more
  if (u < M || u > W - 1 - M || v < M || v > H - 1 - M) return -1;
  const cv::Mat& dRef = ref == View::Left ? descL : descR;
  const cv::Mat& dTgt = ref == View::Left ? descR : descL;
  const uint8_t* centre = dRef.ptr<uint8_t>(v) + static_cast<size_t>(u) * kDescriptorBytes;
  if (descriptorTexture(centre) < cfg.supportTexture) return -1;
  const int dhi = ref == View::Left ? std::min(cfg.dispMax, u - M) : std::min(cfg.dispMax, W - 1 - M - u);
  if (dhi < cfg.supportMinRange) return -1;

  const uint8_t* refTop = dRef.ptr<uint8_t>(v - r);
  const uint8_t* refBottom = dRef.ptr<uint8_t>(v + r);
  const uint8_t* tgtTop = dTgt.ptr<uint8_t>(v - r);
  const uint8_t* tgtBottom = dTgt.ptr<uint8_t>(v + r);
  auto at = [](const uint8_t* row, int x) { return row + static_cast<size_t>(x) * kDescriptorBytes; };
  const uint8_t* refTL = at(refTop, u - r);
  const uint8_t* refTR = at(refTop, u + r);
  const uint8_t* refBL = at(refBottom, u - r);
  const uint8_t* refBR = at(refBottom, u + r);

  int e1 = INT_MAX, e2 = INT_MAX, d1 = -1;
  const int dir = ref == View::Left ? -1 : 1;
  for (int d = 0; d <= dhi; ++d) {
    const int t = u + dir * d;
    const int cost = sad16(refTL, at(tgtTop, t - r)) + sad16(refTR, at(tgtTop, t + r)) +
                     sad16(refBL, at(tgtBottom, t - r)) + sad16(refBR, at(tgtBottom, t + r));
    if (cost < e1) {  // strict: the smallest d wins a tie, and the tied cost becomes E2
      e2 = e1;
      e1 = cost;
      d1 = d;
    } else if (cost < e2) {
      e2 = cost;
    }
  }
  // Integer form of libelas's E1 < threshold * E2 (threshold = percent / 100).
  if (static_cast<long long>(100) * e1 < static_cast<long long>(cfg.supportThresholdPercent) * e2) return d1;
  return -1;
}

cv::Mat supportLattice(const cv::Mat& descL, const cv::Mat& descR, const Config& cfg) {
  const int W = descL.cols, H = descL.rows;
  const int Lw = cfg.latticeCount(W), Lh = cfg.latticeCount(H);
  cv::Mat support(Lh, Lw, CV_16S, cv::Scalar(-1));
  for (int j = 0; j < Lh; ++j) {
    if (!latticeNodeMatchable(j, H, cfg)) continue;
    const int v = j * cfg.candidateStep;
    for (int i = 0; i < Lw; ++i) {
      if (!latticeNodeMatchable(i, W, cfg)) continue;
      const int u = i * cfg.candidateStep;
      const int dL = supportMatch(descL, descR, u, v, View::Left, cfg);
      if (dL < 0) continue;
      const int dR = supportMatch(descL, descR, u - dL, v, View::Right, cfg);
      if (dR >= 0 && std::abs(dL - dR) <= cfg.lrThreshold) support.at<int16_t>(j, i) = static_cast<int16_t>(dL);
    }
  }
  return support;
}

}  // namespace ielas
