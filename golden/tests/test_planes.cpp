// Planes: Q16 rounding on hand-computed cells, exact validity, rasteriser coverage (left mesh and a folded
// right mesh) against an independent point-in-triangle oracle.
#include <cstdlib>
#include <vector>
#include "check.hpp"
#include "ielas/planes.hpp"

using namespace ielas;

namespace {

Config tinyConfig() {
  Config c;
  c.candidateStep = 5;
  return c;
}

cv::Mat lattice(int rows, int cols, std::vector<int> values) {
  cv::Mat m(rows, cols, CV_16S);
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) m.at<int16_t>(j, i) = int16_t(values[size_t(j) * cols + i]);
  return m;
}

// Twice the signed area of (p, q, r): an independent closed point-in-triangle test.
long long cross(long long px, long long py, long long qx, long long qy, long long rx, long long ry) {
  return (qx - px) * (ry - py) - (qy - py) * (rx - px);
}
bool inside(const long long tri[3][2], long long x, long long y) {
  long long c0 = cross(tri[0][0], tri[0][1], tri[1][0], tri[1][1], x, y);
  long long c1 = cross(tri[1][0], tri[1][1], tri[2][0], tri[2][1], x, y);
  long long c2 = cross(tri[2][0], tri[2][1], tri[0][0], tri[0][1], x, y);
  bool neg = c0 < 0 || c1 < 0 || c2 < 0, pos = c0 > 0 || c1 > 0 || c2 > 0;
  if (neg && pos) return false;
  if (c0 == 0 && c1 == 0 && c2 == 0) {  // degenerate triangle: a segment (or point); test the bounding box
    long long xmin = std::min({tri[0][0], tri[1][0], tri[2][0]}), xmax = std::max({tri[0][0], tri[1][0], tri[2][0]});
    long long ymin = std::min({tri[0][1], tri[1][1], tri[2][1]}), ymax = std::max({tri[0][1], tri[1][1], tri[2][1]});
    return x >= xmin && x <= xmax && y >= ymin && y <= ymax;
  }
  return true;
}

// Checks every pixel's owner against "the last triangle of the row's cell row that contains the pixel" and,
// for uncovered right-view pixels, "the owner of the left neighbour". Returns the number of uncovered pixels.
int checkCoverage(const Planes& p, View view) {
  int uncovered = 0;
  std::vector<int> owner;
  for (int v = 0; v < p.H; ++v) {
    rasterRow(p, view, v, owner);
    int cr = 0;
    while (cr + 1 < p.cellRows && p.cellY[cr + 1] <= v) ++cr;
    for (int u = 0; u < p.W; ++u) {
      int expected = -1;
      for (int cc = 0; cc < p.cellCols; ++cc) {
        int xs[2] = {p.cellX[cc], p.cellX[cc + 1]}, ys[2] = {p.cellY[cr], p.cellY[cr + 1]};
        auto vert = [&](int a, int b, long long out[2]) {
          int d = view == View::Right ? p.lattice.at<int16_t>(cr + b, cc + a) : 0;
          out[0] = xs[a] - d;
          out[1] = ys[b];
        };
        long long t0[3][2], t1[3][2];
        vert(0, 0, t0[0]); vert(1, 0, t0[1]); vert(0, 1, t0[2]);  // TL, TR, BL
        vert(1, 0, t1[0]); vert(1, 1, t1[1]); vert(0, 1, t1[2]);  // TR, BR, BL
        if (inside(t0, u, v)) expected = (cr * p.cellCols + cc) * 2;
        if (inside(t1, u, v)) expected = (cr * p.cellCols + cc) * 2 + 1;
      }
      if (expected < 0) {
        ++uncovered;
        CHECK(view == View::Right);
        CHECK(u > 0);
        if (u > 0) {
          std::vector<int> again;
          rasterRow(p, view, v, again);
          CHECK_EQ(owner[u], again[u - 1]);
        }
      } else {
        CHECK_EQ(owner[u], expected);
      }
    }
  }
  return uncovered;
}

}  // namespace

int main() {
  Config cfg = tinyConfig();
  // W = 11: lattice columns 0, 5, 10. H = 8: lattice rows 0, 5, 7 (the last cell row is 2 px high).
  {
    cv::Mat lat = lattice(3, 3, {10, 12, 14,
                                 11, 13, 15,
                                 11, 13, 15});
    Planes p = computePlanes(lat, 11, 8, cfg);
    CHECK_EQ(p.cellRows, 2);
    CHECK_EQ(p.cellCols, 2);
    // Cell (0,0), triangle 0: dA = 12-10 = 2 over w = 5, dB = 11-10 = 1 over h = 5.
    const Plane& L0 = p.left[0];
    CHECK_EQ(L0.a, 26214);   // 2*65536/5 = 26214.4
    CHECK_EQ(L0.b, 13107);   // 65536/5 = 13107.2
    CHECK_EQ(L0.c, 11 * 65536);
    CHECK_EQ(L0.anchorU, 0);
    CHECK_EQ(L0.anchorV, 5);
    CHECK(L0.valid);         // 10*2 < 7*5 and 10*2 < 7*(5-2)
    // Right view: a' = 2/3, b' = 1*5/(5*3) = 1/3, anchor shifted by d_BL = 11.
    const Plane& R0 = p.right[0];
    CHECK_EQ(R0.a, 43691);   // 131072/3 = 43690.67
    CHECK_EQ(R0.b, 21845);   // 65536/3 = 21845.33
    CHECK_EQ(R0.anchorU, -11);
    // Values: exact 10 + 0.4 du + 0.2 dv. (1,0) -> 10.4 -> 10; (2,1) -> 11; (3,1) -> 11.4 -> 11; (0,0) -> 10.
    CHECK_EQ(planeValue(L0, 1, 0), 10);
    CHECK_EQ(planeValue(L0, 2, 1), 11);
    CHECK_EQ(planeValue(L0, 3, 1), 11);
    CHECK_EQ(planeValue(L0, 0, 0), 10);
    CHECK_EQ(planeValue(L0, 5, 0), 12);  // TR vertex: 720896 + 5*26214 - 5*13107 = 786431 -> 12.0000 -> 12
    // Cell (1,1), triangle 1 in the 2-px-high cell: dA = 15-13 = 2 over 5, dB = 15-15 = 0 over 2.
    const Plane& L7 = p.left[7];
    CHECK_EQ(L7.a, 26214);
    CHECK_EQ(L7.b, 0);
    CHECK_EQ(L7.anchorU, 5);
    CHECK_EQ(L7.anchorV, 7);
    CHECK_EQ(planeValue(L7, 10, 7), 15);  // 13*65536 + 5*26214 = 983038 -> 14.99997 -> 15
    // Planes dump: (2, 2, 2, 6).
    std::vector<int> shape;
    std::vector<int32_t> dump = planesDump(p, View::Right, shape);
    CHECK(shape == std::vector<int>({2, 2, 2, 6}));
    CHECK_EQ(dump.size(), size_t(48));
    CHECK_EQ(dump[0], 43691);
    CHECK_EQ(dump[3], -11);
    CHECK_EQ(dump[5], 1);
  }
  // Rounding of a negative slope and exact validity.
  {
    CHECK_EQ(roundDiv(-3 * 65536, 5), -39322);  // -39321.6
    CHECK_EQ(roundDiv(-5, 2), -2);               // -2.5 rounds half up
    CHECK_EQ(roundDiv(5, 2), 3);
    CHECK_EQ(roundDiv(5, -2), -2);
    // Top row 10, 7, 10: triangle 0 of cell 0 has dA = -3 (valid: 30 < 35 and 30 < 7*8);
    // triangle 0 of cell 1 has dA = +3 (left fine, right n = 2: 30 >= 14 -> invalid).
    cv::Mat lat = lattice(3, 3, {10, 7, 10,
                                 10, 7, 10,
                                 10, 7, 10});
    Planes p = computePlanes(lat, 11, 8, cfg);
    CHECK(p.left[0].valid);
    CHECK_EQ(p.left[0].a, -39322);
    CHECK(!p.left[2].valid);
    CHECK(!p.right[2].valid);
    CHECK_EQ(p.right[2].a, 98304);  // 3/2
    // dA = 4 is invalid already in the left view.
    cv::Mat steep = lattice(3, 3, {10, 14, 14, 10, 14, 14, 10, 14, 14});
    CHECK(!computePlanes(steep, 11, 8, cfg).left[0].valid);
  }
  // Left-mesh ownership by hand: shared vertical edges go to the right cell, the diagonal to triangle 1.
  {
    cv::Mat lat = lattice(3, 3, {0, 0, 0, 0, 0, 0, 0, 0, 0});
    Planes p = computePlanes(lat, 11, 8, cfg);
    std::vector<int> owner;
    rasterRow(p, View::Left, 0, owner);
    CHECK_EQ(owner[4], 0);
    CHECK_EQ(owner[5], 2);   // x = 5 is cell 1's left edge
    CHECK_EQ(owner[10], 3);  // top-right corner pixel: triangle 1 of the last cell
    rasterRow(p, View::Left, 1, owner);
    CHECK_EQ(owner[3], 0);   // 3*5 + 1*5 = 20 < 25
    CHECK_EQ(owner[4], 1);   // 4*5 + 1*5 = 25 on the diagonal -> triangle 1
    rasterRow(p, View::Left, 5, owner);
    CHECK_EQ(owner[0], 4);   // row 5 belongs to cell row 1
    rasterRow(p, View::Left, 7, owner);
    CHECK_EQ(owner[10], 7);
    CHECK_EQ(checkCoverage(p, View::Left), 0);
  }
  // Folded right mesh: the middle lattice column has d = 8 > w, so its right-view vertices cross.
  {
    cv::Mat lat = lattice(3, 3, {0, 8, 0,
                                 0, 8, 3,
                                 0, 0, 3});
    Planes p = computePlanes(lat, 11, 8, cfg);
    std::vector<int> owner;
    // Row 0 by hand: cell 0 spans T0 [-3, 0], T1 [-3, -3]; cell 1 spans T0 [-3, 10], T1 [10, 10].
    rasterRow(p, View::Right, 0, owner);
    CHECK_EQ(owner[0], 2);
    CHECK_EQ(owner[9], 2);
    CHECK_EQ(owner[10], 3);
    // Row 5 (cell row 1, its top): right edge at x = 10 - 3 = 7; pixels 8..10 are uncovered -> owner of pixel 7.
    rasterRow(p, View::Right, 5, owner);
    CHECK_EQ(owner[8], owner[7]);
    CHECK_EQ(owner[10], owner[7]);
    CHECK(checkCoverage(p, View::Right) > 0);
    CHECK_EQ(checkCoverage(p, View::Left), 0);
  }
  // Every right-view vertex left of column 0 (d = 20 > W-1): no pixel is covered, every pixel takes the cell
  // row's last triangle (t = 1 of the last cell).
  {
    cv::Mat lat(3, 3, CV_16S, cv::Scalar(20));
    Planes p = computePlanes(lat, 11, 8, cfg);
    std::vector<int> owner;
    rasterRow(p, View::Right, 2, owner);
    CHECK_EQ(owner[0], 3);
    CHECK_EQ(owner[10], 3);
    rasterRow(p, View::Right, 6, owner);
    CHECK_EQ(owner[5], 7);
    CHECK_EQ(planeValue(p.right[7], 5, 6), 20);  // flat plane, extrapolated
  }
  CHECK_THROWS(computePlanes(cv::Mat(2, 2, CV_16S, cv::Scalar(0)), 11, 8, cfg), "lattice must be");
  return testExitCode("test_planes");
}
