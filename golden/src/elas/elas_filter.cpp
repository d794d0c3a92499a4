// libelas support filters (in place, sequential), the support list and the corner points
// (docs/ALGORITHM.md, elas mode).
#include <algorithm>
#include <cstdlib>

#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

void removeInconsistentSupport(cv::Mat& lattice, const Config& cfg) {
  const int rows = lattice.rows, cols = lattice.cols, r = cfg.inconWindowSize;
  // Column-major scan with immediate invalidation: later points see the updated map, as in libelas.
  for (int i = 0; i < cols; ++i) {
    for (int j = 0; j < rows; ++j) {
      const int d = lattice.at<int16_t>(j, i);
      if (d < 0) continue;
      int support = 0;
      for (int i2 = std::max(i - r, 0); i2 <= std::min(i + r, cols - 1); ++i2)
        for (int j2 = std::max(j - r, 0); j2 <= std::min(j + r, rows - 1); ++j2) {
          const int d2 = lattice.at<int16_t>(j2, i2);
          if (d2 >= 0 && std::abs(d - d2) <= cfg.inconThreshold) ++support;
        }
      if (support < cfg.inconMinSupport) lattice.at<int16_t>(j, i) = -1;
    }
  }
}

void removeRedundantSupport(cv::Mat& lattice, int maxDistance, int threshold, bool vertical) {
  const int rows = lattice.rows, cols = lattice.cols;
  const int di = vertical ? 0 : 1, dj = vertical ? 1 : 0;
  for (int i = 0; i < cols; ++i) {
    for (int j = 0; j < rows; ++j) {
      const int d = lattice.at<int16_t>(j, i);
      if (d < 0) continue;
      bool redundant = true;
      for (int sign = -1; sign <= 1 && redundant; sign += 2) {
        bool supported = false;
        int i2 = i, j2 = j;
        for (int k = 0; k < maxDistance; ++k) {
          i2 += sign * di;
          j2 += sign * dj;
          if (i2 < 0 || j2 < 0 || i2 >= cols || j2 >= rows) break;
          const int d2 = lattice.at<int16_t>(j2, i2);
          if (d2 >= 0 && std::abs(d - d2) <= threshold) {
            supported = true;
            break;
          }
        }
        if (!supported) redundant = false;
      }
      if (redundant) lattice.at<int16_t>(j, i) = -1;
    }
  }
}

void addCornerSupportPoints(std::vector<SupportPoint>& points, int width, int height) {
  SupportPoint corners[4] = {{0, 0, 0}, {0, height - 1, 0}, {width - 1, 0, 0}, {width - 1, height - 1, 0}};
  for (SupportPoint& corner : corners) {
    int bestDistance = 10000000;  // libelas's start value; first minimum in list order wins
    for (const SupportPoint& p : points) {
      const int du = corner.u - p.u, dv = corner.v - p.v, distance = du * du + dv * dv;
      if (distance < bestDistance) {
        bestDistance = distance;
        corner.d = p.d;
      }
    }
  }
  for (const SupportPoint& corner : corners) points.push_back(corner);
  // Two more on the right edge, placed so that they map to column W-1 of the right image.
  points.push_back({corners[2].u + corners[2].d, corners[2].v, corners[2].d});
  points.push_back({corners[3].u + corners[3].d, corners[3].v, corners[3].d});
}

std::vector<SupportPoint> supportList(const cv::Mat& lattice, int width, int height, const Config& cfg) {
  std::vector<SupportPoint> points;
  const int step = cfg.candidateStep;
  for (int i = 1; i < lattice.cols; ++i)
    for (int j = 1; j < lattice.rows; ++j) {
      const int d = lattice.at<int16_t>(j, i);
      if (d >= 0) points.push_back({i * step, j * step, d});
    }
  if (cfg.addCorners) addCornerSupportPoints(points, width, height);
  return points;
}

}  // namespace elas
}  // namespace ielas
