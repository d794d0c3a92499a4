// Dense left/right consistency (docs/ALGORITHM.md "## Late stages", lrcheck): one row of each view at a time.
#include "ielas/lr_check.hpp"
#include <cstdlib>
#include <stdexcept>

namespace ielas {

void lrCheck(const cv::Mat& denseL, const cv::Mat& denseR, cv::Mat& outL, cv::Mat& outR, const Config& cfg) {
  if (denseL.type() != CV_16S || denseR.type() != CV_16S || denseL.size() != denseR.size())
    throw std::runtime_error("lrcheck: dense maps must be CV_16S of equal size");
  const int W = denseL.cols, H = denseL.rows;
  outL.create(H, W, CV_16S);
  outR.create(H, W, CV_16S);
  for (int v = 0; v < H; ++v) {
    const int16_t* l = denseL.ptr<int16_t>(v);
    const int16_t* r = denseR.ptr<int16_t>(v);
    int16_t* ol = outL.ptr<int16_t>(v);
    int16_t* orr = outR.ptr<int16_t>(v);
    for (int u = 0; u < W; ++u) {
      // Left pixel u with disparity d sees right column u - d; right pixel u sees left column u + d.
      const int dl = l[u], tl = u - dl;
      ol[u] = (dl >= 0 && tl >= 0 && tl < W && r[tl] >= 0 && std::abs(r[tl] - dl) <= cfg.lrThreshold) ? dl : -1;
      const int dr = r[u], tr = u + dr;
      orr[u] = (dr >= 0 && tr >= 0 && tr < W && l[tr] >= 0 && std::abs(l[tr] - dr) <= cfg.lrThreshold) ? dr : -1;
    }
  }
}

}  // namespace ielas
