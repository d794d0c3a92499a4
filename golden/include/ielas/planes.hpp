// Stage `planes`: regular triangulation of the filled support lattice and fixed-point plane coefficients
// for both views, plus the per-pixel rasteriser that the dense stage (and the hardware) evaluates.
// Full rules: docs/ALGORITHM.md "## Late stages".
#pragma once
#include <cstdint>
#include <vector>
#include <opencv2/core.hpp>
#include "ielas/config.hpp"
#include "ielas/types.hpp"

namespace ielas {

// Fractional bits of the plane coefficients: d(u,v) = (a*u + b*v + c) / 2^kPlaneFracBits.
constexpr int kPlaneFracBits = 16;

// One triangle's plane in one view, in Q.kPlaneFracBits fixed point.
struct Plane {
  int32_t a = 0, b = 0;   // d/du, d/dv (Q16)
  int64_t c = 0;          // offset (Q16); int64 because a*u can be large before adding
  bool valid = false;     // |a| < 0.7 in BOTH views (libelas rule), fixed point
};

// Planes for both triangles of every lattice cell: (cellRows, cellCols, 2). Triangle 0 = (TL,TR,BL), 1 = (TR,BR,BL).
struct Planes {
  int W = 0, H = 0, step = 0;
  int cellRows = 0, cellCols = 0;
  std::vector<Plane> left, right;  // index (cr * cellCols + cc) * 2 + t
  cv::Mat lattice;                 // CV_16S Lh x Lw copy of the filled lattice (vertex disparities)
  const Plane& at(View view, int cr, int cc, int t) const {
    return (view == View::Left ? left : right)[(static_cast<size_t>(cr) * cellCols + cc) * 2 + t];
  }
};

Planes computePlanes(const cv::Mat& lattice, int W, int H, const Config& cfg);

// planes_L/R.npy payload: shape (cellRows, cellCols, 2, 4) <i4, k = (a, b, c, valid); c saturated to int32.
std::vector<int32_t> planesDump(const Planes& p, View view, std::vector<int>& shape);

// Per-pixel plane lookup as the rasteriser defines it: the plane whose triangle owns pixel (u,v) in `view`,
// or nullptr when no plane applies (then dense uses only grid candidates).
const Plane* planeAt(const Planes& p, View view, int u, int v);

// Rounded plane value at (u,v): floor((a*u + b*v + c + 2^(f-1)) / 2^f).
int planeValue(const Plane& pl, int u, int v);

}  // namespace ielas
