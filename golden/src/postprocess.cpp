// Post-processing in bounded streaming forms (docs/ALGORITHM.md "## Late stages", post).
#include "ielas/postprocess.hpp"
#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace ielas {

void removeSmallSegments(cv::Mat& d, int simThreshold, int minSize, int windowRows) {
  const int H = d.rows, W = d.cols;
  if (windowRows < 1) throw std::runtime_error("post: speckleWindowRows must be >= 1");
  std::vector<int16_t> val(size_t(H) * W);
  for (int v = 0; v < H; ++v) std::copy(d.ptr<int16_t>(v), d.ptr<int16_t>(v) + W, val.begin() + ptrdiff_t(v) * W);
  std::vector<int> label(size_t(H) * W, -1);
  std::vector<int> queue;
  queue.reserve(size_t(H) * W);
  std::vector<int> segSize, segMaxRow;
  for (int seed = 0; seed < H * W; ++seed) {
    if (label[seed] >= 0 || val[seed] < 0) continue;
    const int id = int(segSize.size());
    queue.clear();
    queue.push_back(seed);
    label[seed] = id;
    int maxRow = 0;
    // Breadth-first growth; the component does not depend on the visiting order (the relation is symmetric).
    auto visit = [&](int ni, int dp) {
      if (label[ni] >= 0 || val[ni] < 0 || std::abs(val[ni] - dp) > simThreshold) return;
      label[ni] = id;
      queue.push_back(ni);
    };
    for (size_t q = 0; q < queue.size(); ++q) {
      const int p = queue[q], v = p / W, u = p - v * W, dp = val[p];
      maxRow = std::max(maxRow, v);
      if (u > 0) visit(p - 1, dp);
      if (u < W - 1) visit(p + 1, dp);
      if (v > 0) visit(p - W, dp);
      if (v < H - 1) visit(p + W, dp);
    }
    segSize.push_back(int(queue.size()));
    segMaxRow.push_back(maxRow);
  }
  for (int v = 0; v < H; ++v) {
    const int windowLast = v + windowRows - 1;  // last row the streaming form has seen when row v leaves
    int16_t* row = d.ptr<int16_t>(v);
    for (int u = 0; u < W; ++u) {
      const int id = label[size_t(v) * W + u];
      if (id < 0 || segSize[id] >= minSize) continue;
      const bool stillOpen = windowLast < H - 1 && segMaxRow[id] >= windowLast;
      if (!stillOpen) row[u] = -1;
    }
  }
}

namespace {

// Fill value of an interior run between valid values a and b (sixteenths): the mean if they differ by less
// than 3 px, else the smaller one (the background).
inline int16_t gapValue(int a, int b) {
  return int16_t(std::abs(a - b) < 3 * 16 ? (a + b) >> 1 : std::min(a, b));
}

// One line (a row or a column), accessed through a stride.
void fillLine(int16_t* p, int n, ptrdiff_t stride, int gap, bool extrapolate, bool partialEnds) {
  auto V = [&](int i) -> int16_t& { return p[i * stride]; };
  int first = -1, last = -1, prev = -1;
  for (int i = 0; i < n; ++i) {
    if (V(i) < 0) continue;
    if (first < 0) first = i;
    if (prev >= 0 && i - prev - 1 >= 1 && i - prev - 1 <= gap) {
      const int16_t f = gapValue(V(prev), V(i));
      for (int k = prev + 1; k < i; ++k) V(k) = f;
    }
    prev = last = i;
  }
  if (!extrapolate || first < 0) return;
  if (partialEnds) {  // rows: libelas, copy the end values outwards over up to `gap` pixels
    for (int k = std::max(first - gap, 0); k < first; ++k) V(k) = V(first);
    for (int k = last + 1; k <= std::min(last + gap, n - 1); ++k) V(k) = V(last);
  } else {  // columns: an end run is filled only when all of it lies within the window (bounded look-ahead)
    if (first <= gap)
      for (int k = 0; k < first; ++k) V(k) = V(first);
    if (n - 1 - last <= gap)
      for (int k = last + 1; k < n; ++k) V(k) = V(last);
  }
}

}  // namespace

void interpolateGaps(cv::Mat& d16, int rowGap, int colGap, bool extrapolate) {
  const int H = d16.rows, W = d16.cols;
  const ptrdiff_t stride = ptrdiff_t(d16.step1());
  for (int v = 0; v < H; ++v) fillLine(d16.ptr<int16_t>(v), W, 1, rowGap, extrapolate, true);
  for (int u = 0; u < W; ++u) fillLine(d16.ptr<int16_t>(0) + u, H, stride, colGap, extrapolate, false);
}

namespace {

// Weighted mean of taps x[0..7] around centre c (sixteenths); invalid taps (< 0) have weight 0.
inline int16_t meanTaps(const int16_t* x, ptrdiff_t stride, int c) {
  int num = 0, den = 0;
  for (int k = 0; k < 8; ++k) {
    const int xi = x[k * stride];
    if (xi < 0) continue;
    const int diff = std::abs(xi - c);
    const int w = diff < 2 * 16 ? 4 : (diff < 8 * 16 ? 2 : 0);
    num += w * xi;
    den += w;
  }
  return int16_t((2 * num + den) / (2 * den));  // round half up; den >= 4 (the centre)
}

}  // namespace

void adaptiveMean(cv::Mat& d16) {
  const int H = d16.rows, W = d16.cols;
  const ptrdiff_t stride = ptrdiff_t(d16.step1());
  cv::Mat t = d16.clone();
  for (int v = 0; v < H; ++v) {
    const int16_t* in = d16.ptr<int16_t>(v);
    int16_t* out = t.ptr<int16_t>(v);
    for (int p = 4; p <= W - 4; ++p)
      if (in[p] >= 0) out[p] = meanTaps(in + p - 4, 1, in[p]);
  }
  for (int p = 4; p <= H - 4; ++p) {
    const int16_t* in = t.ptr<int16_t>(p);
    int16_t* out = d16.ptr<int16_t>(p);
    for (int u = 0; u < W; ++u)
      if (in[u] >= 0) out[u] = meanTaps(in + u - 4 * stride, stride, in[u]);
  }
  for (int v = 0; v < H; ++v) {  // rows outside the vertical range keep the horizontal result
    if (v >= 4 && v <= H - 4) continue;
    t.row(v).copyTo(d16.row(v));
  }
}

namespace {

// 4th smallest of 7: a 16-comparator sorting network (checked exhaustively on 0/1 inputs), branch-free.
inline void sortPair(int16_t& a, int16_t& b) {
  const int16_t lo = std::min(a, b), hi = std::max(a, b);
  a = lo;
  b = hi;
}
inline int16_t median7Of(int16_t t0, int16_t t1, int16_t t2, int16_t t3, int16_t t4, int16_t t5, int16_t t6) {
  sortPair(t0, t6); sortPair(t2, t3); sortPair(t4, t5);
  sortPair(t0, t2); sortPair(t1, t4); sortPair(t3, t6);
  sortPair(t0, t1); sortPair(t2, t5); sortPair(t3, t4);
  sortPair(t1, t2); sortPair(t4, t6);
  sortPair(t2, t3); sortPair(t4, t5);
  sortPair(t1, t2); sortPair(t3, t4); sortPair(t5, t6);
  return t3;
}

}  // namespace

void median7(cv::Mat& d16) {
  const int H = d16.rows, W = d16.cols;
  cv::Mat m = d16.clone();
  for (int v = 0; v < H; ++v) {
    const int16_t* in = d16.ptr<int16_t>(v);
    int16_t* out = m.ptr<int16_t>(v);
    for (int u = 3; u <= W - 4; ++u)
      if (in[u] >= 0) out[u] = median7Of(in[u - 3], in[u - 2], in[u - 1], in[u], in[u + 1], in[u + 2], in[u + 3]);
  }
  // Vertical pass on the horizontal result, only where the input pixel was valid; elsewhere the input stays.
  cv::Mat out = m.clone();
  for (int v = 3; v <= H - 4; ++v) {
    const int16_t* in = d16.ptr<int16_t>(v);
    const int16_t* r[7];
    for (int k = 0; k < 7; ++k) r[k] = m.ptr<int16_t>(v - 3 + k);
    int16_t* o = out.ptr<int16_t>(v);
    for (int u = 0; u < W; ++u) {
      const int16_t med = median7Of(r[0][u], r[1][u], r[2][u], r[3][u], r[4][u], r[5][u], r[6][u]);
      o[u] = in[u] >= 0 ? med : o[u];
    }
  }
  out.copyTo(d16);
}

cv::Mat postprocess(const cv::Mat& lrL, const Config& cfg) {
  if (lrL.type() != CV_16S) throw std::runtime_error("post: input must be CV_16S");
  cv::Mat d = lrL.clone();
  removeSmallSegments(d, cfg.speckleSimThreshold, cfg.speckleSize, cfg.speckleWindowRows);
  cv::Mat d16(d.size(), CV_16S);
  for (int v = 0; v < d.rows; ++v)
    for (int u = 0; u < d.cols; ++u) {
      const int x = d.at<int16_t>(v, u);
      d16.at<int16_t>(v, u) = int16_t(x < 0 ? -1 : x * 16);
    }
  interpolateGaps(d16, cfg.ipolGapWidth, std::min(cfg.ipolGapWidth, cfg.ipolColumnWindow), cfg.addCorners);
  if (cfg.filterAdaptiveMean) adaptiveMean(d16);
  if (cfg.filterMedian) median7(d16);
  return d16;
}

}  // namespace ielas
