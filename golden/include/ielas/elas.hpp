// `match --mode elas`: a faithful float reimplementation of libelas (Geiger, Roser, Urtasun, ACCV 2010) at full
// resolution, single thread. docs/ALGORITHM.md ("elas mode: departures from libelas") lists the libelas quirks it
// keeps and where this code knowingly differs.
#pragma once
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "ielas/config.hpp"
#include "ielas/types.hpp"

namespace ielas {

// Left disparity map of a rectified 8-bit grey pair: CV_32F, H x W, negative = invalid.
cv::Mat elasMatch(const cv::Mat& left8, const cv::Mat& right8, const Config& cfg);

// The stages, exposed for the unit tests and for stage-by-stage comparison with libelas.
namespace elas {

constexpr float kInvalid = -10.0f;  // libelas's value for "no disparity" after dense matching

// SAD of two 16-byte descriptors, inline because the support and dense loops call it tens of millions of times.
inline int sad16Inline(const uint8_t* a, const uint8_t* b) {
#ifdef __SSE2__
  const __m128i s = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a)),
                                 _mm_loadu_si128(reinterpret_cast<const __m128i*>(b)));
  return _mm_cvtsi128_si32(s) + _mm_extract_epi16(s, 4);
#else
  int sum = 0;
  for (int k = 0; k < 16; ++k) sum += a[k] > b[k] ? a[k] - b[k] : b[k] - a[k];
  return sum;
#endif
}

// Sum of |byte - 128| over one descriptor, inline for the same reason.
inline int textureInline(const uint8_t* desc) {
#ifdef __SSE2__
  const __m128i s = _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(desc)), _mm_set1_epi8(-128));
  return _mm_cvtsi128_si32(s) + _mm_extract_epi16(s, 4);
#else
  int sum = 0;
  for (int k = 0; k < 16; ++k) sum += desc[k] > 128 ? desc[k] - 128 : 128 - desc[k];
  return sum;
#endif
}

struct SupportPoint {
  int u, v, d;  // left-image pixel and disparity
};

// Vertex indices into the support list, and the planes d = a u + b v + c of the left (t1) and right (t2) view.
struct Triangle {
  int c1, c2, c3;
  float t1a = 0, t1b = 0, t1c = 0, t2a = 0, t2b = 0, t2c = 0;
};

// Candidate disparities per grid cell, ascending: count(r, c) entries from list(r, c).
struct CandidateGrid {
  int rows = 0, cols = 0, depth = 0;  // depth = dispMax + 1
  std::vector<int> counts;
  std::vector<int16_t> lists;
  int count(int r, int c) const { return counts[static_cast<size_t>(r) * cols + c]; }
  const int16_t* list(int r, int c) const { return &lists[(static_cast<size_t>(r) * cols + c) * depth]; }
};

// --- support points (elas_support.cpp) ---
// libelas computeMatchingDisparity: best disparity of the 4-corner support window at (u, v) of `ref`, or -1.
int matchSupportPoint(const cv::Mat& descL, const cv::Mat& descR, int u, int v, View ref, const Config& cfg);
// Candidate lattice Dc (CV_16S, rows = ceil(H/step), cols = ceil(W/step)), L/R checked. Lattice row 0 and
// column 0 are never visited and keep 0 (libelas's zero-initialised border quirk).
cv::Mat supportLattice(const cv::Mat& descL, const cv::Mat& descR, const Config& cfg);

// --- support filters and list (elas_filter.cpp) ---
void removeInconsistentSupport(cv::Mat& lattice, const Config& cfg);
void removeRedundantSupport(cv::Mat& lattice, int maxDistance, int threshold, bool vertical);
// Lattice -> list (column-major order, border row/column excluded), plus the corner points when cfg.addCorners.
std::vector<SupportPoint> supportList(const cv::Mat& lattice, int width, int height, const Config& cfg);
void addCornerSupportPoints(std::vector<SupportPoint>& points, int width, int height);

// --- Delaunay triangulation (elas_triangulation.cpp) ---
// Delaunay triangles (counter-clockwise in u-right/v-down pixel axes seen as x/y) of integer points; duplicates
// after the first are dropped. Fewer than 3 non-collinear points give no triangle.
std::vector<Triangle> delaunayTriangulation(const std::vector<cv::Point>& points);
// Left mesh on (u, v), right mesh on (u - d, v).
std::vector<Triangle> triangulateSupport(const std::vector<SupportPoint>& points, View view);

// --- planes (elas_planes.cpp) ---
// Numerical-Recipes gaussj in double with full pivoting; solves A x = b in place (b becomes x). False if singular.
bool gaussJordanSolve(double A[3][3], double b[3]);
void computePlanes(const std::vector<SupportPoint>& points, std::vector<Triangle>& triangles, View view);

// --- candidate grid (elas_grid.cpp) ---
CandidateGrid candidateGrid(const std::vector<SupportPoint>& points, int width, int height, View view,
                            const Config& cfg);

// --- dense matching (elas_dense.cpp) ---
// CV_32F H x W: -10 outside every triangle, -1 where no candidate was evaluated, else the MAP disparity.
cv::Mat denseMatching(const cv::Mat& descL, const cv::Mat& descR, const std::vector<SupportPoint>& points,
                      const std::vector<Triangle>& triangles, const CandidateGrid& grid, View view,
                      const Config& cfg);
// Prior table P[delta], delta = 0..dispMax: cfg.priorTable when it has that size, else libelas's float formula.
std::vector<int> priorTable(const Config& cfg);

// --- left/right check (elas_lr_check.cpp) ---
void leftRightConsistency(cv::Mat& dispL, cv::Mat& dispR, const Config& cfg);

// --- post-processing (elas_postprocess.cpp) ---
void removeSmallSegments(cv::Mat& disp, const Config& cfg);
void gapInterpolation(cv::Mat& disp, const Config& cfg);
// max(0, 4 - |delta|) with libelas's float "abs" mask 0x4F000000: 4 for |delta| < 2, 2 below 8, else 0.
float adaptiveMeanWeight(float delta);
void adaptiveMean(cv::Mat& disp);
void median(cv::Mat& disp);

}  // namespace elas
}  // namespace ielas
