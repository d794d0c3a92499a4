// Post-processing steps on tiny hand-made arrays: bounded speckle removal, gap interpolation (rows, bounded
// columns, extrapolation), adaptive mean weights and rounding, median with invalid taps, the whole chain.
#include <vector>
#include "check.hpp"
#include "ielas/postprocess.hpp"

using namespace ielas;

namespace {

cv::Mat mat(int rows, int cols, std::vector<int> v) {
  cv::Mat m(rows, cols, CV_16S);
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) m.at<int16_t>(j, i) = int16_t(v[size_t(j) * cols + i]);
  return m;
}

void checkEqual(const cv::Mat& got, const cv::Mat& want, int line) {
  for (int j = 0; j < want.rows; ++j)
    for (int i = 0; i < want.cols; ++i)
      if (got.at<int16_t>(j, i) != want.at<int16_t>(j, i)) {
        std::cerr << "line " << line << ": (" << j << "," << i << ") = " << got.at<int16_t>(j, i) << ", expected "
                  << want.at<int16_t>(j, i) << std::endl;
        CHECK(false);
        return;
      }
  CHECK(true);
}

}  // namespace

int main() {
  // Speckles: minSize 4, similarity 1, window 3 rows.
  {
    const std::vector<int> in = {5,  6,  7,  -1, 20, 20,   // 5-6-7 chain: 3 px, closed at row 0 -> removed
                                 -1, -1, -1, -1, 20, 20,   // the 20s: 4 px -> kept
                                 -1, -1, -1, -1, -1, -1,
                                 -1, 9,  -1, -1, -1, -1,   // 9-9-10 column: 3 px over rows 3..5
                                 -1, 9,  -1, -1, -1, -1,
                                 -1, 10, -1, -1, -1, -1,
                                 -1, -1, -1, -1, 30, -1,   // 2 px touching the last row -> removed
                                 1,  3,  -1, -1, 30, -1};  // 1 and 3 differ by 2: two singletons
    cv::Mat d = mat(8, 6, in);
    removeSmallSegments(d, 1, 4, 3);
    // Row 3 sees rows 3..5 and the column segment reaches row 5 (< last row 7): kept. Rows 4, 5 see it closed.
    const std::vector<int> want = {-1, -1, -1, -1, 20, 20, -1, -1, -1, -1, 20, 20, -1, -1, -1, -1, -1, -1,
                                   -1, 9,  -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,
                                   -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1};
    checkEqual(d, mat(8, 6, want), __LINE__);
    cv::Mat whole = mat(8, 6, in);
    removeSmallSegments(whole, 1, 4, 8);  // a window of the whole frame = libelas: the column goes too
    CHECK_EQ(whole.at<int16_t>(3, 1), -1);
    CHECK_EQ(whole.at<int16_t>(1, 5), 20);
    cv::Mat loose = mat(8, 6, in);
    removeSmallSegments(loose, 2, 2, 8);  // similarity 2 joins 1 and 3 into a 2-px segment, kept at minSize 2
    CHECK_EQ(loose.at<int16_t>(7, 0), 1);
    CHECK_EQ(loose.at<int16_t>(7, 1), 3);
  }
  // Row gaps (sixteenths): runs of <= 3 between valid pixels; mean if |a-b| < 3 px (48), else the minimum.
  {
    cv::Mat d = mat(1, 10, {-1, 16, -1, -1, 48, -1, -1, -1, -1, 160});
    interpolateGaps(d, 3, 3, false);
    checkEqual(d, mat(1, 10, {-1, 16, 32, 32, 48, -1, -1, -1, -1, 160}), __LINE__);
    cv::Mat jump = mat(1, 3, {16, -1, 160});
    interpolateGaps(jump, 3, 3, false);
    CHECK_EQ(jump.at<int16_t>(0, 1), 16);
    cv::Mat ends = mat(1, 5, {-1, -1, -1, 32, -1});
    interpolateGaps(ends, 2, 2, true);  // rows: copy outwards over up to 2 px
    checkEqual(ends, mat(1, 5, {-1, 32, 32, 32, 32}), __LINE__);
  }
  // Column gaps and column end runs (filled only when the whole end run is within colGap).
  {
    cv::Mat d = mat(5, 1, {32, -1, -1, 40, -1});
    interpolateGaps(d, 3, 2, false);
    checkEqual(d, mat(5, 1, {32, 36, 36, 40, -1}), __LINE__);
    cv::Mat e = mat(5, 1, {-1, -1, 24, 40, -1});
    interpolateGaps(e, 3, 1, true);
    checkEqual(e, mat(5, 1, {-1, -1, 24, 40, 40}), __LINE__);  // top run of 2 > 1 stays
    cv::Mat g = mat(6, 1, {32, -1, -1, -1, 40, 40});
    interpolateGaps(g, 5000, 2, false);  // a run of 3 exceeds the column window of 2
    CHECK_EQ(g.at<int16_t>(2, 0), -1);
  }
  // Adaptive mean at p = 5 of one row: taps 1..8, centre 160.
  // weights: 160:4 161:4 176:4 200:2 160:4 300:0 (-1):0 170:4 -> 3708 / 22 = 168.55 -> 169.
  {
    const std::vector<int> row = {0, 160, 161, 176, 200, 160, 300, -1, 170, 0, 0, 0};
    cv::Mat d = mat(1, 12, row);
    adaptiveMean(d);
    CHECK_EQ(d.at<int16_t>(0, 5), 169);
    CHECK_EQ(d.at<int16_t>(0, 7), -1);   // an invalid centre stays invalid
    CHECK_EQ(d.at<int16_t>(0, 2), 161);  // p < 4: outside the 8-tap window, unchanged
    cv::Mat col = mat(12, 1, row);
    adaptiveMean(col);
    CHECK_EQ(col.at<int16_t>(5, 0), 169);
    // Rounding half up: taps {16, 17} around a centre only -> (4*16 + 4*17) / 8 = 16.5 -> 17.
    cv::Mat h = mat(1, 9, {-1, -1, -1, -1, 16, 17, -1, -1, -1});
    adaptiveMean(h);
    CHECK_EQ(h.at<int16_t>(0, 4), 17);
  }
  // Median: 4th smallest of 7 taps, invalid taps count as -1.
  {
    cv::Mat d = mat(1, 9, {16, -1, -1, 48, 32, -1, 80, 64, 0});
    median7(d);
    CHECK_EQ(d.at<int16_t>(0, 3), 16);  // -1 -1 -1 16 32 48 80
    CHECK_EQ(d.at<int16_t>(0, 4), 32);  // -1 -1 -1 32 48 64 80
    CHECK_EQ(d.at<int16_t>(0, 5), -1);  // invalid centre stays
    CHECK_EQ(d.at<int16_t>(0, 0), 16);  // border: unchanged
    cv::Mat four = mat(1, 7, {-1, -1, -1, 48, -1, 16, 16});
    median7(four);
    CHECK_EQ(four.at<int16_t>(0, 3), -1);  // four invalid taps invalidate the pixel (as libelas's -10)
    // Every 0/16 pattern of 7 taps: the 4th smallest is 16 iff at least four taps are 16 (0/1 principle).
    int wrong = 0;
    for (int bits = 0; bits < 128; ++bits) {
      cv::Mat row(1, 7, CV_16S);
      int ones = 0;
      for (int k = 0; k < 7; ++k) {
        row.at<int16_t>(0, k) = int16_t((bits >> k) & 1 ? 16 : 0);
        ones += (bits >> k) & 1;
      }
      median7(row);
      wrong += row.at<int16_t>(0, 3) != (ones >= 4 ? 16 : 0);
    }
    CHECK_EQ(wrong, 0);
    cv::Mat col = mat(9, 1, {16, -1, -1, 48, 32, -1, 80, 64, 0});
    median7(col);
    CHECK_EQ(col.at<int16_t>(3, 0), 16);
    CHECK_EQ(col.at<int16_t>(4, 0), 32);
  }
  // The chain: integer input, output disparity * 16.
  {
    Config cfg;
    cfg.speckleSimThreshold = 1;
    cfg.speckleSize = 3;
    cfg.speckleWindowRows = 16;
    cfg.ipolGapWidth = 3;
    cfg.ipolColumnWindow = 32;
    cfg.addCorners = false;
    cfg.filterAdaptiveMean = false;
    cfg.filterMedian = false;
    cv::Mat in = mat(2, 6, {2, -1, 3, 3, -1, 9, 2, 2, 3, 3, -1, -1});
    cv::Mat out = postprocess(in, cfg);
    // 9 is a singleton (removed); the 2/3 segment has 7 px. Row 0 gap at 1: (32+48)/2 = 40.
    checkEqual(out, mat(2, 6, {32, 40, 48, 48, -1, -1, 32, 32, 48, 48, -1, -1}), __LINE__);
  }
  CHECK_THROWS(postprocess(cv::Mat(2, 2, CV_32F), Config()), "CV_16S");
  cv::Mat any = mat(1, 2, {1, 1});
  CHECK_THROWS(removeSmallSegments(any, 1, 4, 0), "speckleWindowRows");
  return testExitCode("test_postprocess");
}
