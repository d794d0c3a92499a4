// Dense L/R check on hand-made rows.
#include "check.hpp"
#include "ielas/lr_check.hpp"

using namespace ielas;

int main() {
  Config cfg;
  cfg.lrThreshold = 2;
  // One row of width 8.
  const int16_t left[8] = {-1, 0, 1, 2, 3, 3, 5, 7};
  const int16_t right[8] = {1, -1, 0, 3, 4, 9, 2, 0};
  cv::Mat dl(1, 8, CV_16S), dr(1, 8, CV_16S), ol, orr;
  for (int u = 0; u < 8; ++u) { dl.at<int16_t>(0, u) = left[u]; dr.at<int16_t>(0, u) = right[u]; }
  lrCheck(dl, dr, ol, orr, cfg);
  // Left u: target u - d. u0 invalid; u1 d0 -> R[1] = -1 invalid; u2 d1 -> R[1] = -1 invalid (not |-1-1| <= 2);
  // u3 d2 -> R[1] invalid; u4 d3 -> R[1] invalid; u5 d3 -> R[2] = 0, |0-3| = 3 > 2 invalid;
  // u6 d5 -> R[1] invalid; u7 d7 -> R[0] = 1, |1-7| invalid.
  const int16_t expL[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
  // Right u: target u + d. u0 d1 -> L[1] = 0, |0-1| = 1 ok; u1 invalid; u2 d0 -> L[2] = 1 ok; u3 d3 -> L[6] = 5 ok;
  // u4 d4 -> L[8] outside; u5 d9 outside; u6 d2 -> L[8] outside; u7 d0 -> L[7] = 7, |7-0| > 2.
  const int16_t expR[8] = {1, -1, 0, 3, -1, -1, -1, -1};
  for (int u = 0; u < 8; ++u) {
    CHECK_EQ(ol.at<int16_t>(0, u), expL[u]);
    CHECK_EQ(orr.at<int16_t>(0, u), expR[u]);
  }
  // A consistent pair within the threshold keeps each side's own value.
  const int16_t l2[8] = {0, 0, 2, 2, 4, 4, 4, 4};
  const int16_t r2[8] = {0, 2, 4, 4, 6, 2, 1, 1};
  for (int u = 0; u < 8; ++u) { dl.at<int16_t>(0, u) = l2[u]; dr.at<int16_t>(0, u) = r2[u]; }
  lrCheck(dl, dr, ol, orr, cfg);
  // L: u2 d2 -> R[0] = 0, |0-2| = 2 ok; u4 d4 -> R[0] = 0, 4 > 2 invalid; u5 d4 -> R[1] = 2 ok; u7 d4 -> R[3] = 4 ok.
  CHECK_EQ(ol.at<int16_t>(0, 2), 2);
  CHECK_EQ(ol.at<int16_t>(0, 4), -1);
  CHECK_EQ(ol.at<int16_t>(0, 5), 4);
  CHECK_EQ(ol.at<int16_t>(0, 7), 4);
  // R: u1 d2 -> L[3] = 2 ok; u4 d6 -> L[10] outside; u5 d2 -> L[7] = 4 ok.
  CHECK_EQ(orr.at<int16_t>(0, 1), 2);
  CHECK_EQ(orr.at<int16_t>(0, 4), -1);
  CHECK_EQ(orr.at<int16_t>(0, 5), 2);
  CHECK_THROWS(lrCheck(cv::Mat(1, 8, CV_16S), cv::Mat(1, 7, CV_16S), ol, orr, cfg), "equal size");
  return testExitCode("test_lr_check");
}
