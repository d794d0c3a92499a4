// Stage `grid`: candidate disparities per grid cell, built from the filtered support points.
#include "ielas/grid.hpp"

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace ielas {

Grid buildGrid(const cv::Mat& filtered, int W, int H, View view, const Config& cfg) {
  CV_Assert(filtered.type() == CV_16S);
  const int gw = cfg.gridCount(W), gh = cfg.gridCount(H), nd = cfg.dispMax + 1;
  // votes[cell][d]: how many support points marked d in the cell (the "smallest" rule only needs > 0).
  std::vector<int> marks(static_cast<size_t>(gw) * gh * nd, 0);
  auto idx = [&](int gy, int gx, int d) { return (static_cast<size_t>(gy) * gw + gx) * nd + d; };
  for (int j = 0; j < filtered.rows; ++j)
    for (int i = 0; i < filtered.cols; ++i) {
      const int d = filtered.at<int16_t>(j, i);
      if (d < 0) continue;
      const int u = cfg.latticeCoord(i, W), v = cfg.latticeCoord(j, H);
      const int x = view == View::Left ? u : u - d;
      if (x < 0) continue;  // cannot happen for checked supports (u - d >= supportMargin), kept for safety
      const int gx = x / cfg.gridSize, gy = v / cfg.gridSize;
      if (gx >= gw || gy >= gh) continue;
      for (int dd = std::max(d - 1, 0); dd <= std::min(d + 1, cfg.dispMax); ++dd) ++marks[idx(gy, gx, dd)];
    }
  // Measurement-only (gridCorners "nearest", not a hardware rule): libelas's MIDDLEBURY corner points, each with
  // the disparity of the nearest filtered support (first in column-major list order on a tie), plus the two
  // points right of the frame; used to check that dropping add_corners costs nothing (docs/ALGORITHM.md).
  if (cfg.addCorners && cfg.gridCorners == "nearest") {
    auto nearest = [&](int cu, int cv) {
      long long best = -1;
      int bestD = -1;
      for (int i = 0; i < filtered.cols; ++i)
        for (int j = 0; j < filtered.rows; ++j) {
          const int d = filtered.at<int16_t>(j, i);
          if (d < 0) continue;
          const long long du = cfg.latticeCoord(i, W) - cu, dv = cfg.latticeCoord(j, H) - cv, e = du * du + dv * dv;
          if (best < 0 || e < best) best = e, bestD = d;
        }
      return bestD;
    };
    const int dTL = nearest(0, 0), dBL = nearest(0, H - 1), dTR = nearest(W - 1, 0), dBR = nearest(W - 1, H - 1);
    const int pts[6][3] = {{0, 0, dTL}, {0, H - 1, dBL}, {W - 1, 0, dTR}, {W - 1, H - 1, dBR},
                           {W - 1 + dTR, 0, dTR}, {W - 1 + dBR, H - 1, dBR}};
    for (const auto& p : pts) {
      const int d = p[2];
      if (d < 0) continue;
      const int x = view == View::Left ? p[0] : p[0] - d;
      if (x < 0) continue;
      const int gx = x / cfg.gridSize, gy = p[1] / cfg.gridSize;
      if (gx >= gw || gy >= gh) continue;
      for (int dd = std::max(d - 1, 0); dd <= std::min(d + 1, cfg.dispMax); ++dd) ++marks[idx(gy, gx, dd)];
    }
  }
  // 3x3 dilation over the cells inside the grid (libelas's wrap-around at the grid's left/right edges and its
  // empty first/last grid rows are not reproduced).
  std::vector<int> dilated(marks.size(), 0);
  for (int gy = 0; gy < gh; ++gy)
    for (int gx = 0; gx < gw; ++gx) {
      int* dst = &dilated[idx(gy, gx, 0)];
      for (int ny = std::max(gy - 1, 0); ny <= std::min(gy + 1, gh - 1); ++ny)
        for (int nx = std::max(gx - 1, 0); nx <= std::min(gx + 1, gw - 1); ++nx) {
          const int* src = &marks[idx(ny, nx, 0)];
          for (int d = 0; d < nd; ++d) dst[d] += src[d];
        }
    }

  Grid g;
  g.rows = gh;
  g.cols = gw;
  g.slots = cfg.storedDisparities;
  g.d.assign(static_cast<size_t>(gh) * gw * g.slots, -1);
  std::vector<int> chosen;
  for (int gy = 0; gy < gh; ++gy)
    for (int gx = 0; gx < gw; ++gx) {
      chosen.clear();
      for (int d = 0; d < nd; ++d)
        if (dilated[idx(gy, gx, d)] > 0) chosen.push_back(d);
      if (static_cast<int>(chosen.size()) > g.slots) {
        if (cfg.gridKeep == "votes") {
          // Most votes first, a tie to the smaller d; then back to ascending order.
          std::stable_sort(chosen.begin(), chosen.end(),
                           [&](int a, int b) { return dilated[idx(gy, gx, a)] > dilated[idx(gy, gx, b)]; });
          chosen.resize(g.slots);
          std::sort(chosen.begin(), chosen.end());
        } else {
          chosen.resize(g.slots);  // "smallest": the first storedDisparities set bits of the cell's mask
        }
      }
      for (size_t k = 0; k < chosen.size(); ++k) g.at(gy, gx, static_cast<int>(k)) = static_cast<int16_t>(chosen[k]);
    }
  return g;
}

std::vector<int> gridShape(const Grid& g) { return {g.rows, g.cols, g.slots}; }

}  // namespace ielas
