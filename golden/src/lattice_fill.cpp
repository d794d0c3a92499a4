// Stage `interp`: fill the lattice nodes that hold no support point.
#include "ielas/lattice_fill.hpp"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace ielas {

bool fillRowR7(const int16_t* row, int Lw, const int16_t* above, int epsilon, int16_t* out) {
  // Nearest support at or left of i / at or right of i, found with one pass each way.
  std::vector<int> left(Lw, -1), right(Lw, -1);
  int last = -1;
  for (int i = 0; i < Lw; ++i) {
    if (row[i] >= 0) last = i;
    left[i] = last;
  }
  if (last < 0) return false;
  last = -1;
  for (int i = Lw - 1; i >= 0; --i) {
    if (row[i] >= 0) last = i;
    right[i] = last;
  }
  for (int i = 0; i < Lw; ++i) {
    if (row[i] >= 0) {
      out[i] = row[i];
      continue;
    }
    const int a = left[i], b = right[i];
    if (a < 0 || b < 0) {  // only one side: row ends take the nearest support's value
      out[i] = row[a < 0 ? b : a];
      continue;
    }
    const int da = row[a], db = row[b];
    if (std::abs(da - db) <= epsilon) {
      // Linear in lattice index, rounded half up: floor((2N + G) / (2G)), N >= 0.
      const int n = da * (b - i) + db * (i - a), g = b - a;
      out[i] = static_cast<int16_t>((2 * n + g) / (2 * g));
    } else {
      const int lo = std::min(da, db), hi = std::max(da, db);
      if (above == nullptr) {
        out[i] = static_cast<int16_t>(lo);  // no row above: the background (lower disparity)
      } else {
        const int up = above[i];
        out[i] = static_cast<int16_t>(std::abs(hi - up) < std::abs(lo - up) ? hi : lo);  // a tie goes to lo
      }
    }
  }
  return true;
}

cv::Mat fillLatticeR7(const cv::Mat& filtered, int epsilon) {
  CV_Assert(filtered.type() == CV_16S);
  const int Lh = filtered.rows, Lw = filtered.cols;
  cv::Mat out(Lh, Lw, CV_16S, cv::Scalar(0));
  for (int j = 0; j < Lh; ++j) {
    int16_t* dst = out.ptr<int16_t>(j);
    const int16_t* above = j > 0 ? out.ptr<int16_t>(j - 1) : nullptr;
    if (fillRowR7(filtered.ptr<int16_t>(j), Lw, above, epsilon, dst)) continue;
    if (j > 0) {
      std::copy(above, above + Lw, dst);  // no support in this row: repeat the row above
      continue;
    }
    // Lattice row 0 never holds supports: it takes the first of rows 1..2 that does (filled as row 0, so
    // jumps take the lower value), else 0. Look-ahead: two lattice rows.
    bool filled = false;
    for (int r = 1; r <= 2 && r < Lh && !filled; ++r) filled = fillRowR7(filtered.ptr<int16_t>(r), Lw, nullptr, epsilon, dst);
    if (!filled) std::fill(dst, dst + Lw, static_cast<int16_t>(0));
  }
  return out;
}

namespace {

// The paper's pair rule: mean (rounded half up) when the two values are within epsilon, else the smaller one.
int pairValue(int da, int db, int epsilon) {
  if (std::abs(da - db) <= epsilon) return (da + db + 1) / 2;
  return std::min(da, db);
}

// Along one line of `count` nodes (stride through `values`), the nearest supports on both sides of node `i`
// within `reach` pixels (inclusive), pixel positions from `coord`. Returns false unless both exist.
template <typename Coord>
bool findPair(const int16_t* values, int stride, int count, int i, int reach, Coord coord, int& da, int& db) {
  const int here = coord(i);
  int a = -1, b = -1;
  for (int k = i - 1; k >= 0 && here - coord(k) <= reach; --k)
    if (values[k * stride] >= 0) { a = k; break; }
  for (int k = i + 1; k < count && coord(k) - here <= reach; ++k)
    if (values[k * stride] >= 0) { b = k; break; }
  if (a < 0 || b < 0) return false;
  da = values[a * stride];
  db = values[b * stride];
  return true;
}

}  // namespace

cv::Mat fillLatticePaper(const cv::Mat& filtered, int W, int H, const Config& cfg) {
  CV_Assert(filtered.type() == CV_16S && filtered.isContinuous());
  const int Lh = filtered.rows, Lw = filtered.cols;
  const int16_t* s = filtered.ptr<int16_t>(0);
  auto colCoord = [&](int i) { return cfg.latticeCoord(i, W); };
  auto rowCoord = [&](int j) { return cfg.latticeCoord(j, H); };
  cv::Mat out(Lh, Lw, CV_16S);
  for (int j = 0; j < Lh; ++j)
    for (int i = 0; i < Lw; ++i) {
      const int d = s[j * Lw + i];
      int da = 0, db = 0, value;
      if (d >= 0) {
        value = d;
      } else if (findPair(s + j * Lw, 1, Lw, i, cfg.sDelta, colCoord, da, db)) {
        value = pairValue(da, db, cfg.epsilon);
      } else if (findPair(s + i, Lw, Lh, j, cfg.sDelta, rowCoord, da, db)) {
        value = pairValue(da, db, cfg.epsilon);  // vertical pairs read supports only, never filled values
      } else {
        value = cfg.fillC;
      }
      out.at<int16_t>(j, i) = static_cast<int16_t>(value);
    }
  return out;
}

cv::Mat fillLattice(const cv::Mat& filtered, int W, int H, const Config& cfg) {
  if (cfg.fillRule == "r7") return fillLatticeR7(filtered, cfg.fillEpsilon);
  if (cfg.fillRule == "paper") return fillLatticePaper(filtered, W, H, cfg);
  throw std::runtime_error("unknown fill rule '" + cfg.fillRule + "' (legal: r7, paper)");
}

}  // namespace ielas
