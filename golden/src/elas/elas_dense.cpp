// libelas dense matching: triangle rasterisation in float and the per-pixel MAP search (docs/ALGORITHM.md, elas mode).
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "ielas/descriptor.hpp"
#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

std::vector<int> priorTable(const Config& cfg) {
  if (static_cast<int>(cfg.priorTable.size()) == cfg.dispMax + 1) return cfg.priorTable;
  // libelas evaluates the prior in float (its parameters are float).
  std::vector<int> table(cfg.dispMax + 1);
  const float beta = static_cast<float>(cfg.beta), gamma = static_cast<float>(cfg.gamma);
  const float sigma = static_cast<float>(cfg.sigma), twoSigmaSquared = 2 * sigma * sigma;
  for (int delta = 0; delta <= cfg.dispMax; ++delta)
    table[delta] = static_cast<int>((-std::log(gamma + std::exp(-(delta * delta) / twoSigmaSquared)) + std::log(gamma)) / beta);
  return table;
}

namespace {

constexpr int kDescriptorMargin = 2;  // dense matching reads columns 2 .. W-3

// libelas converts float -> uint32 -> int32, which on x86-64 is a truncation toward zero through int64.
inline int truncToInt(float x) { return static_cast<int>(static_cast<int64_t>(x)); }

struct MatchContext {
  const cv::Mat* descRef;
  const cv::Mat* descTgt;
  const CandidateGrid* grid;
  const std::vector<int>* prior;
  int width, height, sign;  // sign: -1 left pass (u - d), +1 right pass (u + d)
  int planeRadius, dispMax, matchTexture, gridSize;
  cv::Mat* out;
};

void findMatch(const MatchContext& m, int u, int v, float a, float b, float c, bool valid) {
  if (u < kDescriptorMargin || u >= m.width - kDescriptorMargin || v < 0 || v >= m.height) return;
  const int row = std::max(std::min(v, m.height - 3), 2);
  const uint8_t* f = m.descRef->ptr<uint8_t>(row) + 16 * u;
  if (textureInline(f) < m.matchTexture) return;
  const uint8_t* tgtRow = m.descTgt->ptr<uint8_t>(row);

  const int dPlane = static_cast<int>(a * static_cast<float>(u) + b * static_cast<float>(v) + c);
  const int lo = std::max(dPlane - m.planeRadius, 0), hi = std::min(dPlane + m.planeRadius, m.dispMax);
  const int gx = u / m.gridSize, gy = v / m.gridSize;
  const int count = m.grid->count(gy, gx);
  const int16_t* candidates = m.grid->list(gy, gx);

  int best = 10000, bestD = -1;  // strict "<": the first candidate evaluated wins ties
  for (int k = 0; k < count; ++k) {
    const int d = candidates[k];
    if (d >= lo && d <= hi) continue;
    const int uw = u + m.sign * d;
    if (uw < kDescriptorMargin || uw >= m.width - kDescriptorMargin) continue;
    const int e = sad16Inline(f, tgtRow + 16 * uw);
    if (e < best) {
      best = e;
      bestD = d;
    }
  }
  const int* prior = m.prior->data();
  for (int d = lo; d <= hi; ++d) {
    const int uw = u + m.sign * d;
    if (uw < kDescriptorMargin || uw >= m.width - kDescriptorMargin) continue;
    const int e = sad16Inline(f, tgtRow + 16 * uw) + (valid ? prior[std::abs(d - dPlane)] : 0);
    if (e < best) {
      best = e;
      bestD = d;
    }
  }
  m.out->at<float>(v, u) = bestD >= 0 ? static_cast<float>(bestD) : -1.0f;
}

}  // namespace

cv::Mat denseMatching(const cv::Mat& descL, const cv::Mat& descR, const std::vector<SupportPoint>& points,
                      const std::vector<Triangle>& triangles, const CandidateGrid& grid, View view,
                      const Config& cfg) {
  const int width = descL.cols, height = descL.rows;
  cv::Mat out(height, width, CV_32F, cv::Scalar(kInvalid));
  const std::vector<int> prior = priorTable(cfg);
  MatchContext m{view == View::Left ? &descL : &descR, view == View::Left ? &descR : &descL, &grid, &prior,
                 width, height, view == View::Left ? -1 : 1, cfg.planeRadius, cfg.dispMax, cfg.matchTexture,
                 cfg.gridSize, &out};

  for (const Triangle& t : triangles) {
    const bool left = view == View::Left;
    const float a = left ? t.t1a : t.t2a, b = left ? t.t1b : t.t2b, c = left ? t.t1c : t.t2c;
    const float otherA = left ? t.t2a : t.t1a;
    // A plane is used as prior only if it and its projection into the other image are not too slanted.
    const bool valid = std::fabs(a) < 0.7 && std::fabs(otherA) < 0.7;  // float vs double 0.7, as libelas

    const int corner[3] = {t.c1, t.c2, t.c3};
    float tu[3], tv[3];
    for (int k = 0; k < 3; ++k) {
      const SupportPoint& p = points[corner[k]];
      tu[k] = static_cast<float>(left ? p.u : p.u - p.d);
      tv[k] = static_cast<float>(p.v);
    }
    // Exchange sort by u that swaps only on strictly greater, keeping the order of equal u.
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < j; ++k)
        if (tu[k] > tu[j]) {
          std::swap(tu[j], tu[k]);
          std::swap(tv[j], tv[k]);
        }
    const float Au = tu[0], Av = tv[0], Bu = tu[1], Bv = tv[1], Cu = tu[2], Cv = tv[2];
    const int iA = static_cast<int>(Au), iB = static_cast<int>(Bu), iC = static_cast<int>(Cu);
    float ABa = 0, ACa = 0, BCa = 0;
    if (iA != iB) ABa = (Av - Bv) / (Au - Bu);
    if (iA != iC) ACa = (Av - Cv) / (Au - Cu);
    if (iB != iC) BCa = (Bv - Cv) / (Bu - Cu);
    const float ABb = Av - ABa * Au, ACb = Av - ACa * Au, BCb = Bv - BCa * Bu;

    // Columns [A, B) between lines AC and AB, then [B, C) between AC and BC; rows half-open.
    if (iA != iB)
      for (int u = std::max(iA, 0); u < std::min(iB, width); ++u) {
        const int v1 = truncToInt(ACa * static_cast<float>(u) + ACb);
        const int v2 = truncToInt(ABa * static_cast<float>(u) + ABb);
        for (int v = std::min(v1, v2); v < std::max(v1, v2); ++v) findMatch(m, u, v, a, b, c, valid);
      }
    if (iB != iC)
      for (int u = std::max(iB, 0); u < std::min(iC, width); ++u) {
        const int v1 = truncToInt(ACa * static_cast<float>(u) + ACb);
        const int v2 = truncToInt(BCa * static_cast<float>(u) + BCb);
        for (int v = std::min(v1, v2); v < std::max(v1, v2); ++v) findMatch(m, u, v, a, b, c, valid);
      }
  }
  return out;
}

}  // namespace elas
}  // namespace ielas
