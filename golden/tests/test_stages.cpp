// Support, filter, lattice fill (r7 and paper) and grid on small cases computed by hand (docs/ALGORITHM.md §3-6).
#include <algorithm>
#include <cstdint>
#include <vector>

#include "check.hpp"
#include "ielas/config.hpp"
#include "ielas/filter.hpp"
#include "ielas/grid.hpp"
#include "ielas/lattice_fill.hpp"
#include "ielas/support.hpp"

using namespace ielas;

namespace {

Config smallConfig() {
  Config c = presetConfig("robotics", 31, 48, 16);
  return c;
}

cv::Mat lattice(const std::vector<std::vector<int>>& rows) {
  cv::Mat m(static_cast<int>(rows.size()), static_cast<int>(rows[0].size()), CV_16S);
  for (int j = 0; j < m.rows; ++j)
    for (int i = 0; i < m.cols; ++i) m.at<int16_t>(j, i) = static_cast<int16_t>(rows[j][i]);
  return m;
}

std::vector<int> rowOf(const cv::Mat& m, int j) {
  std::vector<int> r;
  for (int i = 0; i < m.cols; ++i) r.push_back(m.at<int16_t>(j, i));
  return r;
}

int clampByte(int v) { return std::max(0, std::min(255, v)); }

// Descriptors whose only non-neutral byte is byte 0 = f(column): right g(x) = 8x + 10, left g(x - 7) + 3.
// For the left pixel (20, 5) (r = 2) the corners (18, 22) compare with right columns 18 - d, 22 - d:
// cost(d) = 4 |8 (d - 7) + 3|, so E1 = 12 at d = 7 and E2 = 20 at d = 6 (E2/E1 = 0.6).
void makeDescriptors(cv::Mat& descL, cv::Mat& descR) {
  descL.create(16, 48, CV_8UC(16));
  descR.create(16, 48, CV_8UC(16));
  std::fill(descL.data, descL.data + descL.total() * 16, 128);  // setTo cannot fill 16 channels
  std::fill(descR.data, descR.data + descR.total() * 16, 128);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 48; ++x) {
      descR.ptr<uint8_t>(y)[x * 16] = static_cast<uint8_t>(clampByte(8 * x + 10));
      descL.ptr<uint8_t>(y)[x * 16] = static_cast<uint8_t>(clampByte(8 * (x - 7) + 10 + 3));
    }
}

void testSupportMatch() {
  cv::Mat descL, descR;
  makeDescriptors(descL, descR);
  Config c = smallConfig();
  c.supportThresholdPercent = 61;  // 100 * 12 < 61 * 20
  CHECK_EQ(supportMatch(descL, descR, 20, 5, View::Left, c), 7);
  c.supportThresholdPercent = 60;  // 1200 < 1200 fails: the ratio test is strict
  CHECK_EQ(supportMatch(descL, descR, 20, 5, View::Left, c), -1);
  c.supportThresholdPercent = 85;
  // Right reference at 20 - 7 = 13: cost(d) = 4 |8 (d - 7) + 3| again (left columns 13 + d +- 2).
  CHECK_EQ(supportMatch(descL, descR, 13, 5, View::Right, c), 7);
  // Texture of the centre descriptor (20, 5): |byte0 - 128| = |117 - 128| = 11.
  c.supportTexture = 11;
  CHECK_EQ(supportMatch(descL, descR, 20, 5, View::Left, c), 7);
  c.supportTexture = 12;
  CHECK_EQ(supportMatch(descL, descR, 20, 5, View::Left, c), -1);
  c.supportTexture = 10;
  // Margins: M = 5, so v = 4 and v = 11 (> H - 1 - M = 10) fail; u = 15 leaves dhi = 10 (>= supportMinRange 10),
  // u = 14 leaves 9.
  CHECK_EQ(supportMatch(descL, descR, 20, 4, View::Left, c), -1);
  CHECK_EQ(supportMatch(descL, descR, 20, 11, View::Left, c), -1);
  CHECK_EQ(supportMatch(descL, descR, 14, 5, View::Left, c), -1);
  CHECK(supportMatch(descL, descR, 15, 5, View::Left, c) >= 0);
  c.supportMinRange = 11;
  CHECK_EQ(supportMatch(descL, descR, 15, 5, View::Left, c), -1);

  // A tie: right byte 0 shifted so that cost(6) = cost(7) = 8 -> E2 = E1 -> rejected at any threshold.
  cv::Mat tieL = descL.clone();
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 48; ++x) tieL.ptr<uint8_t>(y)[x * 16] = static_cast<uint8_t>(clampByte(8 * (x - 7) + 10 - 4));
  c = smallConfig();
  c.supportThresholdPercent = 100;
  CHECK_EQ(supportMatch(tieL, descR, 20, 5, View::Left, c), -1);
}

void testSupportLatticeAndLrCheck() {
  cv::Mat descL, descR;
  makeDescriptors(descL, descR);
  Config c = smallConfig();
  cv::Mat s = supportLattice(descL, descR, c);
  CHECK_EQ(s.rows, 4);   // v = 0, 5, 10, 15 (= H - 1)
  CHECK_EQ(s.cols, 11);  // u = 0, 5, ..., 45, 47
  CHECK_EQ(s.at<int16_t>(1, 4), 7);  // (20, 5)
  for (int i = 0; i < s.cols; ++i) CHECK_EQ(s.at<int16_t>(0, i), -1);  // row 0 never holds supports
  for (int j = 0; j < s.rows; ++j) CHECK_EQ(s.at<int16_t>(j, 0), -1);  // nor column 0
  // L/R check: flatten the right centre descriptor (13, 5) (texture 0): the right match fails, so does the support.
  descR.at<cv::Vec<uint8_t, 16>>(5, 13) = cv::Vec<uint8_t, 16>::all(128);
  CHECK_EQ(supportLattice(descL, descR, c).at<int16_t>(1, 4), -1);
  // A disagreeing right match: left columns 21 and 25 (rows 3 and 7) copy right columns 11 and 15, so the right
  // reference at 13 finds cost(10) = 0 -> dR = 10, while the left match at 20 (columns 18, 22) still gives 7.
  // |7 - 10| = 3 > lrThreshold 2 -> rejected; with lrThreshold 3 accepted.
  makeDescriptors(descL, descR);
  for (int row : {3, 7}) {
    descL.ptr<uint8_t>(row)[21 * 16] = descR.ptr<uint8_t>(row)[11 * 16];
    descL.ptr<uint8_t>(row)[25 * 16] = descR.ptr<uint8_t>(row)[15 * 16];
  }
  CHECK_EQ(supportMatch(descL, descR, 20, 5, View::Left, c), 7);
  CHECK_EQ(supportMatch(descL, descR, 13, 5, View::Right, c), 10);
  CHECK_EQ(supportLattice(descL, descR, c).at<int16_t>(1, 4), -1);
  c.lrThreshold = 3;
  CHECK_EQ(supportLattice(descL, descR, c).at<int16_t>(1, 4), 7);
  c.lrThreshold = 2;
  // The check's tolerance: with lrThreshold 0 an equal right disparity still passes.
  makeDescriptors(descL, descR);
  c.lrThreshold = 0;
  CHECK_EQ(supportLattice(descL, descR, c).at<int16_t>(1, 4), 7);
}

void testFilter() {
  Config c = smallConfig();
  c.inconWindowSize = 1;
  c.inconThreshold = 2;
  c.inconMinSupport = 3;
  cv::Mat s = lattice({{-1, -1, -1, -1, -1},
                       {-1, 10, 11, -1, 30},
                       {-1, 12, -1, 20, 30},
                       {-1, -1, -1, -1, 33}});
  cv::Mat f = filterSupport(s, c);
  // (1,1)=10: 3x3 holds 10, 11, 12 (all within 2) -> 3 -> kept. (1,2)=11: 10, 11, 12 -> 3 kept (20 is 9 away).
  // (2,1)=12: 10, 11, 12 -> kept. (2,3)=20: 11? |11-20| > 2; 30, 30 > 2 -> count 1 -> removed.
  // (1,4)=30: 30, 30 (and 20 no) -> 2 -> removed. (2,4)=30: 30, 30, 33? |3| > 2 -> 2 -> removed.
  // (3,4)=33: 30 (2,4)? |3| > 2 -> 1 -> removed.
  CHECK(rowOf(f, 0) == std::vector<int>({-1, -1, -1, -1, -1}));
  CHECK(rowOf(f, 1) == std::vector<int>({-1, 10, 11, -1, -1}));
  CHECK(rowOf(f, 2) == std::vector<int>({-1, 12, -1, -1, -1}));
  CHECK(rowOf(f, 3) == std::vector<int>({-1, -1, -1, -1, -1}));
  // Snapshot: with min support 2, (1,4) and (2,4) keep each other although (3,4) is removed.
  c.inconMinSupport = 2;
  cv::Mat g = filterSupport(s, c);
  CHECK(rowOf(g, 1) == std::vector<int>({-1, 10, 11, -1, 30}));
  CHECK(rowOf(g, 2) == std::vector<int>({-1, 12, -1, -1, 30}));
  CHECK(rowOf(g, 3) == std::vector<int>({-1, -1, -1, -1, -1}));
}

std::vector<int> fillRow(const std::vector<int>& row, const std::vector<int>* above, int epsilon) {
  std::vector<int16_t> r(row.begin(), row.end()), a, out(row.size(), -99);
  if (above) a.assign(above->begin(), above->end());
  bool any = fillRowR7(r.data(), static_cast<int>(r.size()), above ? a.data() : nullptr, epsilon, out.data());
  if (!any) return {};
  return std::vector<int>(out.begin(), out.end());
}

void testR7Row() {
  // Linear: between 10 (i=1) and 16 (i=4): i=2: (2*(10*2 + 16*1) + 3) / 6 = 75/6 = 12; i=3: (2*42 + 3)/6 = 14.
  // Row ends copy the nearest support.
  CHECK(fillRow({-1, 10, -1, -1, 16, -1}, nullptr, 15) == std::vector<int>({10, 10, 12, 14, 16, 16}));
  // Half up: between 0 and 1 over 2 steps, 0.5 -> 1; between 0 and 3 over 2 steps 1.5 -> 2; 1 and 0: 0.5 -> 1.
  CHECK(fillRow({0, -1, 1}, nullptr, 15) == std::vector<int>({0, 1, 1}));
  CHECK(fillRow({0, -1, 3}, nullptr, 15) == std::vector<int>({0, 2, 3}));
  CHECK(fillRow({1, -1, 0}, nullptr, 15) == std::vector<int>({1, 1, 0}));
  // Epsilon is inclusive: |10 - 25| = 15 interpolates, 16 does not.
  CHECK(fillRow({10, -1, -1, 25}, nullptr, 15) == std::vector<int>({10, 15, 20, 25}));
  // A jump (|10 - 40| > 15) without a row above takes the lower value.
  CHECK(fillRow({-1, 10, -1, 40, -1}, nullptr, 15) == std::vector<int>({10, 10, 10, 40, 40}));
  // Up-select: the value nearer to the filled row above; a tie goes to the lower (background) value.
  std::vector<int> nearHi = {0, 0, 35, 0, 0}, tie = {0, 0, 25, 0, 0}, nearLo = {0, 0, 12, 0, 0};
  CHECK(fillRow({-1, 10, -1, 40, -1}, &nearHi, 15) == std::vector<int>({10, 10, 40, 40, 40}));
  CHECK(fillRow({-1, 10, -1, 40, -1}, &tie, 15) == std::vector<int>({10, 10, 10, 40, 40}));
  CHECK(fillRow({-1, 10, -1, 40, -1}, &nearLo, 15) == std::vector<int>({10, 10, 10, 40, 40}));
  // A row without supports reports false.
  CHECK(fillRow({-1, -1, -1}, nullptr, 15).empty());
}

void testR7Lattice() {
  // Row 0 takes row 2 (row 1 is empty), filled as row 0 (jump -> lower); row 1 copies row 0; row 2 uses the
  // up-select against row 1; row 3 (empty) copies row 2.
  cv::Mat a = fillLatticeR7(lattice({{-1, -1, -1, -1, -1},
                                     {-1, -1, -1, -1, -1},
                                     {-1, 20, -1, 60, -1},
                                     {-1, -1, -1, -1, -1}}), 15);
  CHECK(rowOf(a, 0) == std::vector<int>({20, 20, 20, 60, 60}));
  CHECK(rowOf(a, 1) == std::vector<int>({20, 20, 20, 60, 60}));
  CHECK(rowOf(a, 2) == std::vector<int>({20, 20, 20, 60, 60}));
  CHECK(rowOf(a, 3) == std::vector<int>({20, 20, 20, 60, 60}));
  // Row 1 has a support: row 0 takes row 1 even if row 2 differs; row 2 picks the high value where row 1 is near it.
  cv::Mat b = fillLatticeR7(lattice({{-1, -1, -1, -1, -1},
                                     {-1, 50, -1, -1, 50},
                                     {-1, 10, -1, 40, -1}}), 15);
  CHECK(rowOf(b, 0) == std::vector<int>({50, 50, 50, 50, 50}));
  CHECK(rowOf(b, 1) == std::vector<int>({50, 50, 50, 50, 50}));
  CHECK(rowOf(b, 2) == std::vector<int>({10, 10, 40, 40, 40}));
  // No support in rows 1..2: row 0 is 0 even though row 3 has one; rows 1..2 copy it.
  cv::Mat z = fillLatticeR7(lattice({{-1, -1, -1}, {-1, -1, -1}, {-1, -1, -1}, {-1, 9, -1}}), 15);
  CHECK(rowOf(z, 0) == std::vector<int>({0, 0, 0}));
  CHECK(rowOf(z, 2) == std::vector<int>({0, 0, 0}));
  CHECK(rowOf(z, 3) == std::vector<int>({9, 9, 9}));
}

void testPaperFill() {
  // W = 26 (nodes at 0..25, step 5), H = 21 (rows at 0..20); sDelta 10 px, epsilon 3, C 7.
  Config c = presetConfig("robotics", 63, 64, 32);
  c.fillRule = "paper";
  c.sDelta = 10;
  c.epsilon = 3;
  c.fillC = 7;
  cv::Mat s = lattice({{-1, -1, -1, -1, -1, -1},
                       {-1, 10, -1, 13, -1, -1},
                       {-1, -1, -1, 30, -1, -1},
                       {-1, -1, -1, -1, -1, -1},
                       {-1, 20, -1, -1, -1, -1}});
  cv::Mat f = fillLattice(s, 26, 21, c);
  CHECK_EQ(f.at<int16_t>(1, 2), 12);  // horizontal pair 10 / 13, |3| <= 3: mean 11.5 rounded up
  CHECK_EQ(f.at<int16_t>(1, 3), 13);  // a support keeps its value
  CHECK_EQ(f.at<int16_t>(1, 0), 7);   // no left neighbour, column 0 has no supports: C
  CHECK_EQ(f.at<int16_t>(1, 4), 7);   // only a left neighbour, nothing vertical: C
  CHECK_EQ(f.at<int16_t>(3, 1), 10);  // vertical pair 10 (10 px up, inclusive) / 20 (5 px down): min
  CHECK_EQ(f.at<int16_t>(2, 1), 10);  // horizontal has no left support -> vertical 10 (5 up) / 20 (10 down): min
  CHECK_EQ(f.at<int16_t>(3, 3), 7);   // vertical: 30 above, nothing below within 10 px: C
  CHECK_EQ(f.at<int16_t>(2, 2), 7);   // horizontal: nothing left; vertical: nothing: C
  CHECK_EQ(f.at<int16_t>(0, 1), 7);   // nothing above row 0
  c.sDelta = 9;                       // the 10 px pairs are now out of reach
  cv::Mat g = fillLattice(s, 26, 21, c);
  CHECK_EQ(g.at<int16_t>(3, 1), 7);
  CHECK_EQ(g.at<int16_t>(1, 2), 12);
  c.epsilon = 2;                       // |10 - 13| > 2: the minimum
  CHECK_EQ(fillLattice(s, 26, 21, c).at<int16_t>(1, 2), 10);
  // The extra last node sits at W-1 = 25 here (on the step); with W = 27 it sits at 26, 1 px after 25.
  Config c27 = presetConfig("robotics", 63, 64, 32);
  c27.fillRule = "paper";
  c27.sDelta = 6;
  c27.epsilon = 3;
  c27.fillC = 7;
  cv::Mat s27 = lattice({{-1, -1, -1, -1, -1, -1, -1},
                         {-1, -1, -1, -1, 11, -1, 11},
                         {-1, -1, -1, -1, -1, -1, -1},
                         {-1, -1, -1, -1, -1, -1, -1},
                         {-1, -1, -1, -1, -1, -1, -1}});
  cv::Mat f27 = fillLattice(s27, 27, 21, c27);
  CHECK_EQ(f27.at<int16_t>(1, 5), 11);  // 25 px: left 20 (5 px), right 26 (1 px)
}

std::vector<int> cell(const Grid& g, int r, int c) {
  std::vector<int> v;
  for (int k = 0; k < g.slots; ++k) v.push_back(g.at(r, c, k));
  return v;
}

void testGrid() {
  // W = 60, H = 40, gridSize 20: 2 x 3 cells. Lattice 9 x 13.
  Config c = presetConfig("robotics", 31, 60, 40);
  c.storedDisparities = 4;
  cv::Mat s(9, 13, CV_16S, cv::Scalar(-1));
  s.at<int16_t>(1, 1) = 5;   // (u=5, v=5): left cell (0,0), right x = 0 -> cell (0,0)
  s.at<int16_t>(5, 9) = 10;  // (45, 25): left cell (1,2), right x = 35 -> cell (1,1)
  Grid left = buildGrid(s, 60, 40, View::Left, c);
  CHECK_EQ(left.rows, 2);
  CHECK_EQ(left.cols, 3);
  CHECK_EQ(left.slots, 4);
  CHECK(cell(left, 0, 0) == std::vector<int>({4, 5, 6, -1}));
  CHECK(cell(left, 1, 0) == std::vector<int>({4, 5, 6, -1}));
  CHECK(cell(left, 0, 1) == std::vector<int>({4, 5, 6, 9}));  // 6 candidates capped to the 4 smallest
  CHECK(cell(left, 1, 1) == std::vector<int>({4, 5, 6, 9}));
  CHECK(cell(left, 0, 2) == std::vector<int>({9, 10, 11, -1}));
  Grid right = buildGrid(s, 60, 40, View::Right, c);
  CHECK(cell(right, 0, 2) == std::vector<int>({9, 10, 11, -1}));  // (1,1) dilates over all six cells
  CHECK(cell(right, 1, 0) == std::vector<int>({4, 5, 6, 9}));
  // Votes: a second 10 in cell (1,2) gives 9, 10, 11 two votes each in cell (0,1); 4 wins the tie with 5, 6.
  s.at<int16_t>(6, 9) = 10;
  c.gridKeep = "votes";
  Grid voted = buildGrid(s, 60, 40, View::Left, c);
  CHECK(cell(voted, 0, 1) == std::vector<int>({4, 9, 10, 11}));
  // Clipping at 0 and dispMax: d = 0 marks 0, 1; d = 31 marks 30, 31.
  cv::Mat e(9, 13, CV_16S, cv::Scalar(-1));
  e.at<int16_t>(1, 1) = 0;
  e.at<int16_t>(1, 11) = 31;  // u = 55: cell column 2
  c.gridKeep = "smallest";
  Grid clipped = buildGrid(e, 60, 40, View::Left, c);
  CHECK(cell(clipped, 0, 0) == std::vector<int>({0, 1, -1, -1}));
  CHECK(cell(clipped, 0, 2) == std::vector<int>({30, 31, -1, -1}));
  CHECK(cell(clipped, 1, 1) == std::vector<int>({0, 1, 30, 31}));

  // Measurement-only corner points (MIDDLEBURY): one support (5, 5, d=5) is every corner's nearest point, so the
  // corner (59, 0) marks 4..6 in cell (0,2), which is empty without corners. Right grid: TR' = (64, 0, 5) maps
  // to x = 59 -> cell (0,2) too.
  Config m = presetConfig("middlebury", 31, 60, 40);
  cv::Mat one(9, 13, CV_16S, cv::Scalar(-1));
  one.at<int16_t>(1, 1) = 5;
  CHECK(cell(buildGrid(one, 60, 40, View::Left, m), 0, 2) == std::vector<int>(20, -1));
  m.gridCorners = "nearest";
  std::vector<int> expected(20, -1);
  expected[0] = 4, expected[1] = 5, expected[2] = 6;
  CHECK(cell(buildGrid(one, 60, 40, View::Left, m), 0, 2) == expected);
  CHECK(cell(buildGrid(one, 60, 40, View::Right, m), 1, 2) == expected);
  Config rob = presetConfig("robotics", 31, 60, 40);  // addCorners 0: the knob has no effect
  rob.gridCorners = "nearest";
  CHECK(cell(buildGrid(one, 60, 40, View::Left, rob), 0, 2) == std::vector<int>(20, -1));
}

}  // namespace

int main() {
  testSupportMatch();
  testSupportLatticeAndLrCheck();
  testFilter();
  testR7Row();
  testR7Lattice();
  testPaperFill();
  testGrid();
  return testExitCode("test_stages");
}
