// Stage `filter`: inconsistency filter over a snapshot of the support lattice.
#include "ielas/filter.hpp"

#include <algorithm>
#include <cstdlib>

namespace ielas {

cv::Mat filterSupport(const cv::Mat& support, const Config& cfg) {
  CV_Assert(support.type() == CV_16S);
  const int Lh = support.rows, Lw = support.cols, k = cfg.inconWindowSize;
  cv::Mat out(Lh, Lw, CV_16S, cv::Scalar(-1));
  for (int j = 0; j < Lh; ++j)
    for (int i = 0; i < Lw; ++i) {
      const int d = support.at<int16_t>(j, i);
      if (d < 0) continue;
      int agreeing = 0;
      for (int j2 = std::max(0, j - k); j2 <= std::min(Lh - 1, j + k); ++j2)
        for (int i2 = std::max(0, i - k); i2 <= std::min(Lw - 1, i + k); ++i2) {
          const int d2 = support.at<int16_t>(j2, i2);
          if (d2 >= 0 && std::abs(d2 - d) <= cfg.inconThreshold) ++agreeing;
        }
      if (agreeing >= cfg.inconMinSupport) out.at<int16_t>(j, i) = static_cast<int16_t>(d);
    }
  return out;
}

}  // namespace ielas
