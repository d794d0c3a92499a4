// ielas-post --config NAME|FILE.json --in LRCHECK_L.npy --out DISPARITY.npy: stage `post` alone on a given
// left L/R-check map (H x W <i2, -1 invalid), for hardware tests that need maps no image pair produces
// (segments crossing the speckle window, gaps at frame edges). Same code as the pipeline: ielas::postprocess.
#include <cstdio>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "ielas/config.hpp"
#include "ielas/npy.hpp"
#include "ielas/postprocess.hpp"

int main(int argc, char** argv) {
  try {
    std::string config, in, out;
    for (int i = 1; i + 1 < argc; i += 2) {
      const std::string a = argv[i];
      if (a == "--config") config = argv[i + 1];
      else if (a == "--in") in = argv[i + 1];
      else if (a == "--out") out = argv[i + 1];
      else throw std::runtime_error("unknown option " + a);
    }
    if (config.empty() || in.empty() || out.empty())
      throw std::runtime_error("usage: ielas-post --config NAME|FILE.json --in LRCHECK_L.npy --out DISPARITY.npy");
    const ielas::Config cfg = ielas::loadConfig(config);
    const ielas::NpyArray a = ielas::readNpy(in);
    if (a.descr != "<i2" || a.shape.size() != 2) throw std::runtime_error(in + ": expected a 2-D <i2 array");
    cv::Mat lr(a.shape[0], a.shape[1], CV_16S);
    for (int v = 0; v < lr.rows; ++v)
      for (int u = 0; u < lr.cols; ++u) lr.at<int16_t>(v, u) = int16_t(a.value(size_t(v) * lr.cols + u));
    ielas::writeNpyMat(out, ielas::postprocess(lr, cfg));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ielas-post: %s\n", e.what());
    return 1;
  }
}
