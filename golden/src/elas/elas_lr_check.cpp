// libelas dense left/right consistency check on copies of both maps (docs/ALGORITHM.md, elas mode).
#include <cmath>

#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

void leftRightConsistency(cv::Mat& dispL, cv::Mat& dispR, const Config& cfg) {
  const cv::Mat copyL = dispL.clone(), copyR = dispR.clone();
  const int width = dispL.cols, height = dispL.rows;
  const float threshold = static_cast<float>(cfg.lrThreshold);
  for (int v = 0; v < height; ++v) {
    const float* l = copyL.ptr<float>(v);
    const float* r = copyR.ptr<float>(v);
    float* outL = dispL.ptr<float>(v);
    float* outR = dispR.ptr<float>(v);
    for (int u = 0; u < width; ++u) {
      const float d1 = l[u], d2 = r[u];
      const float warp1 = static_cast<float>(u) - d1, warp2 = static_cast<float>(u) + d2;
      if (d1 >= 0 && warp1 >= 0 && warp1 < width) {
        if (std::fabs(r[static_cast<int>(warp1)] - d1) > threshold) outL[u] = kInvalid;
      } else {
        outL[u] = kInvalid;
      }
      if (d2 >= 0 && warp2 >= 0 && warp2 < width) {
        if (std::fabs(l[static_cast<int>(warp2)] - d2) > threshold) outR[u] = kInvalid;
      } else {
        outR[u] = kInvalid;
      }
    }
  }
}

}  // namespace elas
}  // namespace ielas
