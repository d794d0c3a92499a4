// Regular triangulation planes and rasteriser (docs/ALGORITHM.md "## Late stages", planes).
#include "ielas/planes.hpp"
#include <algorithm>
#include <cstdlib>
#include <stdexcept>

namespace ielas {

int64_t roundDiv(int64_t n, int64_t d) {
  if (d < 0) { n = -n; d = -d; }
  int64_t num = 2 * n + d, den = 2 * d;
  int64_t q = num / den;
  if ((num % den != 0) && (num < 0)) --q;  // floor, not truncation
  return q;
}

namespace {

// Plane of one triangle in both views from its anchor BL and the two lattice differences:
//   dA = change of d across the cell width w (along the top edge for triangle 0, the bottom edge for 1),
//   dB = change of d across the cell height h (left edge TL->BL for 0, right edge TR->BR for 1).
void makePlanes(int x0, int y1, int w, int h, int dBL, int dA, int dB, Plane& L, Plane& R) {
  const int64_t one = int64_t(1) << kPlaneFracBits;
  const int n = w - dA;  // width of the triangle's horizontal edge in the right view
  // |a| < 0.7 in both views: 10|dA| < 7w and 10|dA| < 7|n| (a_right = dA / n).
  bool valid = 10 * std::abs(dA) < 7 * w && n != 0 && 10 * std::abs(dA) < 7 * std::abs(n);
  L.a = int32_t(roundDiv(dA * one, w));
  L.b = int32_t(roundDiv(dB * one, h));
  L.c = int32_t(dBL * one);
  L.anchorU = x0;
  L.anchorV = y1;
  L.valid = valid;
  if (n != 0) {  // right plane: a' = a/(1-a) = dA/n, b' = b/(1-a) = dB*w/(h*n)
    R.a = int32_t(roundDiv(dA * one, n));
    R.b = int32_t(roundDiv(int64_t(dB) * w * one, int64_t(h) * n));
  } else {  // collapsed right triangle: constant plane through BL
    R.a = 0;
    R.b = 0;
  }
  R.c = L.c;
  R.anchorU = x0 - dBL;
  R.anchorV = y1;
  R.valid = valid;
}

}  // namespace

Planes computePlanes(const cv::Mat& lattice, int W, int H, const Config& cfg) {
  const int Lw = cfg.latticeCount(W), Lh = cfg.latticeCount(H);
  if (lattice.type() != CV_16S || lattice.rows != Lh || lattice.cols != Lw)
    throw std::runtime_error("planes: lattice must be CV_16S " + std::to_string(Lh) + "x" + std::to_string(Lw));
  if (Lw < 2 || Lh < 2) throw std::runtime_error("planes: lattice needs at least 2x2 nodes");
  Planes p;
  p.W = W;
  p.H = H;
  p.cellCols = Lw - 1;
  p.cellRows = Lh - 1;
  p.lattice = lattice.clone();
  for (int i = 0; i < Lw; ++i) p.cellX.push_back(cfg.latticeCoord(i, W));
  for (int j = 0; j < Lh; ++j) p.cellY.push_back(cfg.latticeCoord(j, H));
  p.left.resize(size_t(p.cellRows) * p.cellCols * 2);
  p.right.resize(p.left.size());
  for (int cr = 0; cr < p.cellRows; ++cr) {
    for (int cc = 0; cc < p.cellCols; ++cc) {
      const int x0 = p.cellX[cc], x1 = p.cellX[cc + 1], y0 = p.cellY[cr], y1 = p.cellY[cr + 1];
      const int w = x1 - x0, h = y1 - y0;
      const int dTL = lattice.at<int16_t>(cr, cc), dTR = lattice.at<int16_t>(cr, cc + 1);
      const int dBL = lattice.at<int16_t>(cr + 1, cc), dBR = lattice.at<int16_t>(cr + 1, cc + 1);
      const size_t k = (size_t(cr) * p.cellCols + cc) * 2;
      makePlanes(x0, y1, w, h, dBL, dTR - dTL, dBL - dTL, p.left[k], p.right[k]);
      makePlanes(x0, y1, w, h, dBL, dBR - dBL, dBR - dTR, p.left[k + 1], p.right[k + 1]);
    }
  }
  return p;
}

std::vector<int32_t> planesDump(const Planes& p, View view, std::vector<int>& shape) {
  shape = {p.cellRows, p.cellCols, 2, 6};
  std::vector<int32_t> out;
  out.reserve(p.left.size() * 6);
  for (const Plane& pl : p.view(view)) {
    out.insert(out.end(), {pl.a, pl.b, pl.c, pl.anchorU, pl.anchorV, pl.valid ? 1 : 0});
  }
  return out;
}

int planeValue(const Plane& pl, int u, int v) {
  int64_t q = int64_t(pl.c) + int64_t(pl.a) * (u - pl.anchorU) + int64_t(pl.b) * (v - pl.anchorV);
  q += int64_t(1) << (kPlaneFracBits - 1);
  return int(q >> kPlaneFracBits);  // arithmetic shift = floor
}

namespace {

// Floor and ceiling of n / d for d > 0.
int64_t floorDiv(int64_t n, int64_t d) { return n >= 0 ? n / d : -((-n + d - 1) / d); }
int64_t ceilDiv(int64_t n, int64_t d) { return -floorDiv(-n, d); }

}  // namespace

void rasterRow(const Planes& p, View view, int v, std::vector<int>& owner) {
  const int W = p.W;
  owner.assign(W, -1);
  // Image row v belongs to the last cell row whose top row is <= v (later cell rows win shared edges).
  int cr = int(std::upper_bound(p.cellY.begin(), p.cellY.end(), v) - p.cellY.begin()) - 1;
  cr = std::clamp(cr, 0, p.cellRows - 1);
  const int y0 = p.cellY[cr], y1 = p.cellY[cr + 1], h = y1 - y0;
  const int up = y1 - v, down = v - y0;  // weights of the top and bottom vertex rows, scaled by h
  const bool right = view == View::Right;
  auto shift = [&](int j, int i) { return right ? int(p.lattice.at<int16_t>(j, i)) : 0; };
  for (int cc = 0; cc < p.cellCols; ++cc) {
    const int x0 = p.cellX[cc], x1 = p.cellX[cc + 1];
    // Crossing points of row v with the left edge, the diagonal and the right edge, times h (exact integers).
    const int64_t eH = int64_t(x0 - shift(cr, cc)) * up + int64_t(x0 - shift(cr + 1, cc)) * down;
    const int64_t gH = int64_t(x1 - shift(cr, cc + 1)) * up + int64_t(x0 - shift(cr + 1, cc)) * down;
    const int64_t fH = int64_t(x1 - shift(cr, cc + 1)) * up + int64_t(x1 - shift(cr + 1, cc + 1)) * down;
    const int64_t spans[2][2] = {{std::min(eH, gH), std::max(eH, gH)}, {std::min(gH, fH), std::max(gH, fH)}};
    for (int t = 0; t < 2; ++t) {
      int64_t lo = std::max<int64_t>(ceilDiv(spans[t][0], h), 0);
      int64_t hi = std::min<int64_t>(floorDiv(spans[t][1], h), W - 1);
      const int id = (cr * p.cellCols + cc) * 2 + t;
      for (int64_t u = lo; u <= hi; ++u) owner[size_t(u)] = id;  // later triangles overwrite
    }
  }
  // Right view only: uncovered pixels take the owner of the nearest covered pixel to their left; a row with no
  // covered pixel at all takes the cell row's last triangle. (Pixel 0 uncovered implies the whole row is.)
  int last = -1;
  for (int u = 0; u < W; ++u) {
    if (owner[u] >= 0) last = owner[u];
    else owner[u] = last;
  }
  if (owner[0] < 0) {
    const int fallback = last >= 0 ? last : (cr * p.cellCols + p.cellCols - 1) * 2 + 1;
    for (int u = 0; u < W && owner[u] < 0; ++u) owner[u] = fallback;  // defensive: cannot happen when partial
  }
}

}  // namespace ielas
