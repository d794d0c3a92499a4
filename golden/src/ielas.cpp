// The `ielas` pipeline: early stages (descriptor .. grid) and the late stages, plus the stage dumps.
#include "ielas/ielas.hpp"

#include <ctime>
#include <stdexcept>
#include <sys/stat.h>

#include "ielas/dense.hpp"
#include "ielas/descriptor.hpp"
#include "ielas/filter.hpp"
#include "ielas/grid.hpp"
#include "ielas/lattice_fill.hpp"
#include "ielas/lr_check.hpp"
#include "ielas/npy.hpp"
#include "ielas/postprocess.hpp"
#include "ielas/support.hpp"

namespace ielas {

IelasFrame runIelas(const cv::Mat& left8, const cv::Mat& right8, const Config& cfg) {
  IelasFrame f;
  std::clock_t last = std::clock();  // process CPU time: steadier than wall time on a shared machine
  auto lap = [&](const char* stage) {
    std::clock_t now = std::clock();
    f.stageMs.emplace_back(stage, 1000.0 * static_cast<double>(now - last) / CLOCKS_PER_SEC);
    last = now;
  };
  f.W = left8.cols;
  f.H = left8.rows;
  f.descL = computeDescriptor(left8, cfg);
  f.descR = computeDescriptor(right8, cfg);
  lap("descriptor");
  f.support = supportLattice(f.descL, f.descR, cfg);
  lap("support");
  f.filtered = filterSupport(f.support, cfg);
  f.lattice = fillLattice(f.filtered, f.W, f.H, cfg);
  lap("filter+interp");
  f.gridL = buildGrid(f.filtered, f.W, f.H, View::Left, cfg);
  f.gridR = buildGrid(f.filtered, f.W, f.H, View::Right, cfg);
  lap("grid");
  // Late stages may still be stubs that throw; the early arrays stay usable either way.
  try {
    f.planes = computePlanes(f.lattice, f.W, f.H, cfg);
    f.hasPlanes = true;
    lap("planes");
    f.denseL = denseMatch(f.descL, f.descR, f.planes, f.gridL, View::Left, cfg);
    f.denseR = denseMatch(f.descL, f.descR, f.planes, f.gridR, View::Right, cfg);
    f.hasDense = true;
    lap("dense");
    lrCheck(f.denseL, f.denseR, f.lrL, f.lrR, cfg);
    f.hasLrCheck = true;
    lap("lrcheck");
    f.disparity = postprocess(f.lrL, cfg);
    f.hasDisparity = true;
    lap("post");
  } catch (const std::runtime_error& e) {
    f.lateError = e.what();
  }
  return f;
}

void dumpIelas(const IelasFrame& f, const std::string& dir) {
  mkdir(dir.c_str(), 0777);  // an existing directory is fine; a failure shows up at the first write
  auto path = [&](const char* name) { return dir + "/" + name + ".npy"; };
  writeNpyMat(path("descriptor_L"), f.descL);
  writeNpyMat(path("descriptor_R"), f.descR);
  writeNpyMat(path("support_L"), f.support);
  writeNpyMat(path("support_filtered_L"), f.filtered);
  writeNpyMat(path("lattice_L"), f.lattice);
  writeNpy(path("grid_L"), "<i2", {f.gridL.rows, f.gridL.cols, f.gridL.slots}, f.gridL.d.data());
  writeNpy(path("grid_R"), "<i2", {f.gridR.rows, f.gridR.cols, f.gridR.slots}, f.gridR.d.data());
  if (f.hasPlanes) {
    std::vector<int> shape;
    std::vector<int32_t> left = planesDump(f.planes, View::Left, shape);
    writeNpy(path("planes_L"), "<i4", shape, left.data());
    std::vector<int32_t> right = planesDump(f.planes, View::Right, shape);
    writeNpy(path("planes_R"), "<i4", shape, right.data());
  }
  if (f.hasDense) {
    writeNpyMat(path("dense_L"), f.denseL);
    writeNpyMat(path("dense_R"), f.denseR);
  }
  if (f.hasLrCheck) {
    writeNpyMat(path("lrcheck_L"), f.lrL);
    writeNpyMat(path("lrcheck_R"), f.lrR);
  }
  if (f.hasDisparity) writeNpyMat(path("disparity"), f.disparity);
}

cv::Mat disparityToFloat(const cv::Mat& disparity16) {
  CV_Assert(disparity16.type() == CV_16S);
  cv::Mat out(disparity16.size(), CV_32F);
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const int v = disparity16.at<int16_t>(y, x);
      out.at<float>(y, x) = v < 0 ? -1.0f : static_cast<float>(v) / 16.0f;
    }
  return out;
}

}  // namespace ielas
