// Stage `planes`: regular triangulation of the filled support lattice, fixed-point plane coefficients for both
// views, and the per-row rasteriser that tells the dense stage (and the hardware) which plane owns each pixel.
// Every rule (rounding, validity, coverage, uncovered right-view pixels) is in docs/ALGORITHM.md "## Late stages".
#pragma once
#include <cstdint>
#include <vector>
#include <opencv2/core.hpp>
#include "ielas/config.hpp"
#include "ielas/types.hpp"

namespace ielas {

// Fractional bits of plane coefficients and values: d(u,v) = (c + a*(u-anchorU) + b*(v-anchorV)) / 2^16.
constexpr int kPlaneFracBits = 16;

// One triangle's plane in one view. The anchor is the triangle's bottom-left lattice vertex BL, shifted to
// (x0 - d_BL, y1) in the right view; c = d_BL << 16 exactly, so the plane passes through BL without rounding.
struct Plane {
  int32_t a = 0, b = 0;         // d/du, d/dv in Q16 (roundDiv of exact rationals)
  int32_t c = 0;                // value at the anchor, Q16
  int32_t anchorU = 0, anchorV = 0;
  bool valid = false;           // libelas |a| < 0.7 in BOTH views, decided exactly on integers
};

// Triangle 0 = (TL,TR,BL), triangle 1 = (TR,BR,BL) of lattice cell (cr, cc); index (cr*cellCols + cc)*2 + t.
struct Planes {
  int W = 0, H = 0;
  int cellRows = 0, cellCols = 0;
  std::vector<int> cellX, cellY;   // pixel coordinate of lattice column/row k (size cellCols+1 / cellRows+1)
  cv::Mat lattice;                 // CV_16S (cellRows+1) x (cellCols+1) vertex disparities
  std::vector<Plane> left, right;
  const std::vector<Plane>& view(View v) const { return v == View::Left ? left : right; }
};

Planes computePlanes(const cv::Mat& lattice, int W, int H, const Config& cfg);

// planes_L/R.npy payload: shape (cellRows, cellCols, 2, 6) <i4, k = (a, b, c, anchorU, anchorV, valid).
std::vector<int32_t> planesDump(const Planes& p, View view, std::vector<int>& shape);

// Owner of every pixel of image row v in `view`: owner[u] = triangle index into p.view(view) (always >= 0).
void rasterRow(const Planes& p, View view, int v, std::vector<int>& owner);

// Plane value rounded to an integer disparity: floor((Q16 value + 2^15) / 2^16). May lie outside 0..dispMax.
int planeValue(const Plane& pl, int u, int v);

// Exact rounded division floor((2n + d) / (2d)) (half up), d != 0. Shared with the tests.
int64_t roundDiv(int64_t n, int64_t d);

}  // namespace ielas
