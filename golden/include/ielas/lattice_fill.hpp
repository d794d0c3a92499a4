// Stage `interp`: every lattice node gets a disparity (docs/ALGORITHM.md §5).
#pragma once
#include <cstdint>

#include <opencv2/core.hpp>

#include "ielas/config.hpp"

namespace ielas {

// lattice_L: CV_16S Lh x Lw, every node in 0..dispMax. `filtered` is support_filtered_L (-1 = none).
// The rule is cfg.fillRule: "r7" (docs/ALGORITHM.md, interp) or "paper" (sDelta px, epsilon, fillC).
cv::Mat fillLattice(const cv::Mat& filtered, int W, int H, const Config& cfg);

cv::Mat fillLatticeR7(const cv::Mat& filtered, int epsilon);
cv::Mat fillLatticePaper(const cv::Mat& filtered, int W, int H, const Config& cfg);

// R7 rule 1 on one lattice row: supports keep their value, other nodes interpolate between the nearest
// supports left and right. `above` is the filled row above (nullptr for lattice row 0: jumps take the lower
// value). Returns false (and leaves `out` untouched) when the row holds no support.
bool fillRowR7(const int16_t* row, int Lw, const int16_t* above, int epsilon, int16_t* out);

}  // namespace ielas
