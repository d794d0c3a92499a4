// The whole `ielas` mode: every stage in order, with the arrays the dumps hold (docs/interfaces.md §3).
#pragma once
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "ielas/config.hpp"
#include "ielas/planes.hpp"
#include "ielas/types.hpp"

namespace ielas {

struct IelasFrame {
  int W = 0, H = 0;
  cv::Mat descL, descR;        // H x W CV_8UC(16)
  cv::Mat support, filtered;   // Lh x Lw CV_16S, -1 = none
  cv::Mat lattice;             // Lh x Lw CV_16S, every node filled
  Grid gridL, gridR;
  // Late stages; `lateError` holds why they stopped when one is not available yet.
  bool hasPlanes = false, hasDense = false, hasLrCheck = false, hasDisparity = false;
  Planes planes;
  cv::Mat denseL, denseR, lrL, lrR;  // H x W CV_16S, -1 = invalid
  cv::Mat disparity;                 // H x W CV_16S, disparity * 16, -1 = invalid
  std::string lateError;
  std::vector<std::pair<std::string, double>> stageMs;  // CPU time per stage, in order (for --time)
};

// Runs the pipeline on an 8-bit grey pair that already passed the size checks.
IelasFrame runIelas(const cv::Mat& left8, const cv::Mat& right8, const Config& cfg);

// Writes every array that exists as <dir>/<name>.npy (descriptor_L/R, support_L, support_filtered_L, lattice_L,
// grid_L/R, planes_L/R, dense_L/R, lrcheck_L/R, disparity). Creates `dir`.
void dumpIelas(const IelasFrame& frame, const std::string& dir);

// disparity.npy (d * 16, -1 invalid) as float pixels, negative = invalid.
cv::Mat disparityToFloat(const cv::Mat& disparity16);

}  // namespace ielas
