// Dense matching: libelas find_match in integers (docs/ALGORITHM.md "## Late stages", dense).
#include "ielas/dense.hpp"
#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

namespace ielas {

namespace {

// Sum of absolute differences of two 16-byte descriptors.
inline int sad16(const uint8_t* a, const uint8_t* b) {
#ifdef __SSE2__
  __m128i s = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a)),
                           _mm_loadu_si128(reinterpret_cast<const __m128i*>(b)));
  return _mm_cvtsi128_si32(s) + _mm_extract_epi16(s, 4);
#else
  int s = 0;
  for (int k = 0; k < 16; ++k) s += std::abs(int(a[k]) - int(b[k]));
  return s;
#endif
}

// texture = sum |byte - 128|.
inline int texture16(const uint8_t* a) {
  static const uint8_t mid[16] = {128, 128, 128, 128, 128, 128, 128, 128,
                                  128, 128, 128, 128, 128, 128, 128, 128};
  return sad16(a, mid);
}

// Costs are >= -kCostOffset (SAD >= 0, priors > -4096) and < 2^22, so (cost + offset) << 8 fits an int.
constexpr int kCostOffset = 4096;
constexpr int kNoCandidate = 0x7fffffff;

}  // namespace

cv::Mat denseMatch(const cv::Mat& descL, const cv::Mat& descR, const Planes& planes, const Grid& grid, View view,
                   const Config& cfg) {
  const int W = planes.W, H = planes.H;
  if (descL.rows != H || descL.cols != W || descR.size() != descL.size() || descL.type() != CV_8UC(16) ||
      descR.type() != CV_8UC(16))
    throw std::runtime_error("dense: descriptors must be CV_8UC(16) of the frame size " + std::to_string(W) + "x" +
                             std::to_string(H));
  if (grid.rows != cfg.gridCount(H) || grid.cols != cfg.gridCount(W) ||
      grid.d.size() != size_t(grid.rows) * grid.cols * grid.slots)
    throw std::runtime_error("dense: grid must have gridCount(H) x gridCount(W) cells");
  if (grid.slots >= 128 || 2 * cfg.planeRadius + 1 >= 128 || int(cfg.priorTable.size()) <= cfg.dispMax)
    throw std::runtime_error("dense: grid slots and plane range must be < 128, priorTable must cover 0..dispMax");
  const int m = cfg.descriptorMargin, R = cfg.planeRadius, dispMax = cfg.dispMax;
  const bool left = view == View::Left;
  const cv::Mat& ref = left ? descL : descR;
  const cv::Mat& tgt = left ? descR : descL;
  const std::vector<Plane>& pl = planes.view(view);
  cv::Mat out(H, W, CV_16S, cv::Scalar(-1));
  std::vector<int> owner;
  for (int v = m; v <= H - 1 - m; ++v) {
    rasterRow(planes, view, v, owner);
    const uint8_t* refRow = ref.ptr<uint8_t>(v);
    const uint8_t* tgtRow = tgt.ptr<uint8_t>(v);
    int16_t* outRow = out.ptr<int16_t>(v);
    const int gr = v / cfg.gridSize;
    for (int u = m; u <= W - 1 - m; ++u) {
      const int16_t* cell = &grid.d[(size_t(gr) * grid.cols + u / cfg.gridSize) * grid.slots];
      const uint8_t* f = refRow + 16 * u;
      if (texture16(f) < cfg.matchTexture) continue;
      const Plane& plane = pl[owner[u]];
      const int dp = planeValue(plane, u, v);
      const int lo = std::max(dp - R, 0), hi = std::min(dp + R, dispMax);
      // Target column of disparity d, legal iff it has a defined descriptor.
      auto target = [&](int d) { return left ? u - d : u + d; };
      // Branch-free "first evaluated wins": the key orders by cost, then by evaluation position
      // (grid slot k < 128, then 128 + d - lo for the plane range).
      int best = kNoCandidate;
      // (a) grid candidates outside [lo, hi], ascending, SAD only.
      for (int k = 0; k < grid.slots; ++k) {
        const int d = cell[k];
        if (d < 0) break;
        if (d >= lo && d <= hi) continue;
        const int t = target(d);
        if (t < m || t > W - 1 - m) continue;
        best = std::min(best, ((sad16(f, tgtRow + 16 * t) + kCostOffset) << 8) | k);
      }
      // (b) plane range lo..hi ascending, SAD plus the prior when the plane is valid.
      const int* prior = cfg.priorTable.data();
      for (int d = lo; d <= hi; ++d) {
        const int t = target(d);
        if (t < m || t > W - 1 - m) continue;
        const int e = sad16(f, tgtRow + 16 * t) + (plane.valid ? prior[std::abs(d - dp)] : 0);
        best = std::min(best, ((e + kCostOffset) << 8) | (128 + d - lo));
      }
      int bestD = -1;
      if (best != kNoCandidate) {
        const int order = best & 255;
        bestD = order >= 128 ? lo + order - 128 : cell[order];
      }
      outRow[u] = int16_t(bestD);
    }
  }
  return out;
}

}  // namespace ielas
