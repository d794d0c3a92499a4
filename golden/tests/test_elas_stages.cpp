// elas mode early stages on hand-computed cases: support filters, planes, Delaunay, grid quirk, rasterisation.
#include <cmath>
#include <random>
#include <set>

#include <opencv2/imgproc.hpp>

#include "check.hpp"
#include "ielas/descriptor.hpp"
#include "ielas/elas.hpp"

using namespace ielas;

namespace {

void testInconsistentFilterBorderZeros() {
  Config cfg;
  cfg.inconWindowSize = 5;
  cfg.inconThreshold = 5;
  cfg.inconMinSupport = 5;
  // 3x3 lattice: row 0 and column 0 hold the never-visited zeros. (1,1) = 3 is backed by the 5 zeros
  // (|3 - 0| <= 5) and itself; (2,2) = 40 only by itself and goes.
  cv::Mat lattice = (cv::Mat_<int16_t>(3, 3) << 0, 0, 0, 0, 3, -1, 0, -1, 40);
  elas::removeInconsistentSupport(lattice, cfg);
  CHECK_EQ(lattice.at<int16_t>(1, 1), 3);
  CHECK_EQ(lattice.at<int16_t>(2, 2), -1);
  CHECK_EQ(lattice.at<int16_t>(0, 0), 0);
}

void testRedundantFilter() {
  // Two lattice columns of 5 rows. Column 0 (zeros): rows 1..3 have equal neighbours on both sides and go,
  // each seeing the updated column. Column 1 = 0 4 4 4 9: only row 2 has support above and below.
  cv::Mat lattice = (cv::Mat_<int16_t>(5, 2) << 0, 0, 0, 4, 0, 4, 0, 4, 0, 9);
  elas::removeRedundantSupport(lattice, 5, 1, true);
  const int16_t col0[5] = {0, -1, -1, -1, 0}, col1[5] = {0, 4, -1, 4, 9};
  for (int j = 0; j < 5; ++j) {
    CHECK_EQ(lattice.at<int16_t>(j, 0), col0[j]);
    CHECK_EQ(lattice.at<int16_t>(j, 1), col1[j]);
  }
  // Horizontal pass on one row 5 5 5 7: the middle 5 is redundant, the ends are not, 7 has no match.
  cv::Mat row = (cv::Mat_<int16_t>(1, 4) << 5, 5, 5, 7);
  elas::removeRedundantSupport(row, 5, 1, false);
  CHECK_EQ(row.at<int16_t>(0, 0), 5);
  CHECK_EQ(row.at<int16_t>(0, 1), -1);
  CHECK_EQ(row.at<int16_t>(0, 2), 5);
  CHECK_EQ(row.at<int16_t>(0, 3), 7);
}

void testCornerPoints() {
  // 100x50 image, points (10,10,3) and (90,40,7): TL, BL -> 3; TR, BR -> 7 (BL is nearer to (10,10):
  // 100+1600 vs 6400+100); then (99+7, 0, 7) and (99+7, 49, 7).
  std::vector<elas::SupportPoint> p = {{10, 10, 3}, {90, 40, 7}};
  elas::addCornerSupportPoints(p, 100, 50);
  CHECK_EQ(static_cast<int>(p.size()), 8);
  const int expected[6][3] = {{0, 0, 3}, {0, 49, 3}, {99, 0, 7}, {99, 49, 7}, {106, 0, 7}, {106, 49, 7}};
  for (int k = 0; k < 6; ++k) {
    CHECK_EQ(p[2 + k].u, expected[k][0]);
    CHECK_EQ(p[2 + k].v, expected[k][1]);
    CHECK_EQ(p[2 + k].d, expected[k][2]);
  }
}

void testPlanes() {
  // d = 0.5 u + 0.2 v + 1 through (0,0,1), (10,0,6), (0,10,3).
  double A[3][3] = {{0, 0, 1}, {10, 0, 1}, {0, 10, 1}};
  double b[3] = {1, 6, 3};
  CHECK(elas::gaussJordanSolve(A, b));
  CHECK(std::fabs(b[0] - 0.5) < 1e-12);
  CHECK(std::fabs(b[1] - 0.2) < 1e-12);
  CHECK(std::fabs(b[2] - 1.0) < 1e-12);
  // Right view of the same points: u - d = -1, 4, -3 -> solve a(u-d) + b v + c = d by hand:
  // from points 1, 2: 5a = 5 -> a = 1; c = 1 + a = 2; point 3: -3 + 10 b + 2 = 3 -> b = 0.4.
  std::vector<elas::SupportPoint> pts = {{0, 0, 1}, {10, 0, 6}, {0, 10, 3}, {0, 0, 1}, {5, 5, 2}, {10, 10, 3}};
  std::vector<elas::Triangle> tris = {{0, 1, 2}, {3, 4, 5}};
  elas::computePlanes(pts, tris, View::Left);
  CHECK(std::fabs(tris[0].t1a - 0.5f) < 1e-6f && std::fabs(tris[0].t1b - 0.2f) < 1e-6f &&
        std::fabs(tris[0].t1c - 1.0f) < 1e-6f);
  CHECK(std::fabs(tris[0].t2a - 1.0f) < 1e-6f && std::fabs(tris[0].t2b - 0.4f) < 1e-6f &&
        std::fabs(tris[0].t2c - 2.0f) < 1e-6f);
  // Collinear corners: singular -> the plane (0, 0, 0).
  CHECK_EQ(tris[1].t1a, 0.0f);
  CHECK_EQ(tris[1].t1b, 0.0f);
  CHECK_EQ(tris[1].t1c, 0.0f);
}

// Independent checks of a triangulation: every circumcircle empty (exact), areas add up to the hull's.
void checkDelaunay(const std::vector<cv::Point>& pts, const std::vector<elas::Triangle>& tris) {
  double area = 0;
  for (const elas::Triangle& t : tris) {
    const cv::Point a = pts[t.c1], b = pts[t.c2], c = pts[t.c3];
    const int64_t o = static_cast<int64_t>(b.x - a.x) * (c.y - a.y) - static_cast<int64_t>(b.y - a.y) * (c.x - a.x);
    CHECK(o > 0);
    area += o / 2.0;
    for (const cv::Point& d : pts) {
      const int64_t adx = a.x - d.x, ady = a.y - d.y, bdx = b.x - d.x, bdy = b.y - d.y, cdx = c.x - d.x,
                    cdy = c.y - d.y;
      const int64_t det = (adx * adx + ady * ady) * (bdx * cdy - bdy * cdx) +
                          (bdx * bdx + bdy * bdy) * (cdx * ady - cdy * adx) +
                          (cdx * cdx + cdy * cdy) * (adx * bdy - ady * bdx);
      CHECK(det <= 0);
    }
  }
  std::vector<cv::Point> hull;
  cv::convexHull(pts, hull);
  CHECK_EQ(area, cv::contourArea(hull));
}

void testDelaunay() {
  // Square plus centre: 4 triangles, all using the centre; the duplicate corner is dropped.
  std::vector<cv::Point> pts = {{0, 0}, {10, 0}, {0, 10}, {10, 10}, {5, 5}, {10, 0}};
  std::vector<elas::Triangle> tris = elas::delaunayTriangulation(pts);
  CHECK_EQ(static_cast<int>(tris.size()), 4);
  for (const elas::Triangle& t : tris) {
    CHECK(t.c1 == 4 || t.c2 == 4 || t.c3 == 4);
    CHECK(t.c1 != 5 && t.c2 != 5 && t.c3 != 5);
  }
  checkDelaunay(pts, tris);
  // Collinear points: no triangle.
  CHECK(elas::delaunayTriangulation({{0, 0}, {5, 0}, {10, 0}}).empty());
  // Random lattice points (many cocircular quadruples) and collinear hull runs.
  std::mt19937 rng(7);
  std::vector<cv::Point> lattice;
  std::set<std::pair<int, int>> used;
  while (lattice.size() < 400) {
    const int x = 5 * static_cast<int>(rng() % 60), y = 5 * static_cast<int>(rng() % 30);
    if (used.insert({x, y}).second) lattice.emplace_back(x, y);
  }
  std::vector<elas::Triangle> t2 = elas::delaunayTriangulation(lattice);
  checkDelaunay(lattice, t2);
}

void testGridQuirk() {
  Config cfg;
  cfg.gridSize = 20;
  cfg.dispMax = 10;
  // 100x100 -> 5x5 cells. Points in cells (row 2, col 2) d 5, (0, 0) d 2, (2, 0) d 8.
  std::vector<elas::SupportPoint> pts = {{50, 50, 5}, {5, 5, 2}, {5, 45, 8}};
  elas::CandidateGrid g = elas::candidateGrid(pts, 100, 100, View::Left, cfg);
  CHECK_EQ(g.rows, 5);
  CHECK_EQ(g.cols, 5);
  // Cell (1,1) ORs cells 0..2, 5..7, 10..12 -> {1,2,3} + {7,8,9} + {4,5,6}.
  CHECK_EQ(g.count(1, 1), 9);
  for (int k = 0; k < 9; ++k) CHECK_EQ(g.list(1, 1)[k], k + 1);
  // Linear walk: cell (1,0) (index 5) is never written, row 0 and row 4 neither, nor cell (3,4) (index 19).
  CHECK_EQ(g.count(1, 0), 0);
  CHECK_EQ(g.count(0, 0), 0);
  CHECK_EQ(g.count(4, 2), 0);
  CHECK_EQ(g.count(3, 4), 0);
  // Cell (1,4) (index 9) wraps to index 10 = cell (2,0): {7,8,9}.
  CHECK_EQ(g.count(1, 4), 3);
  CHECK_EQ(g.list(1, 4)[0], 7);
  // Cell (3,3) (index 18, the last written) sees (2,2): {4,5,6}.
  CHECK_EQ(g.count(3, 3), 3);
  CHECK_EQ(g.list(3, 3)[0], 4);
  // Right view: the point (50,50,5) moves to column floor(45/20) = 2, (5,45,8) to floor(-3/20) = -1: dropped.
  elas::CandidateGrid r = elas::candidateGrid(pts, 100, 100, View::Right, cfg);
  CHECK_EQ(r.count(1, 4), 0);
  CHECK_EQ(r.count(1, 1), 6);
}

void testRasterisation() {
  // One triangle (10,10), (20,10), (10,20) of constant disparity 5 on 40x40 all-zero descriptors. Sorted by u:
  // A (10,10), B (10,20), C (20,10): only part 2 runs, u = 10..19, rows 10 .. 30-u-1 -> 55 pixels. All SADs
  // are 0, so the prior decides: P[0] = -14 at d = 5.
  Config cfg;
  cfg.dispMax = 10;
  cfg.gridSize = 20;
  cfg.planeRadius = 2;
  cfg.matchTexture = 0;
  cfg.beta = 0.02;
  cfg.gamma = 3.0;
  cfg.sigma = 1.0;
  cfg.priorTable = {-14, -9, -2, 0, 0, 0, 0, 0, 0, 0, 0};
  cv::Mat desc(40, 40, CV_8UC(16), cv::Scalar::all(0));
  std::vector<elas::SupportPoint> pts = {{10, 10, 5}, {20, 10, 5}, {10, 20, 5}};
  std::vector<elas::Triangle> tris = {{0, 1, 2}};
  elas::computePlanes(pts, tris, View::Left);
  elas::CandidateGrid empty;
  empty.rows = 2;
  empty.cols = 2;
  empty.depth = 11;
  empty.counts.assign(4, 0);
  empty.lists.assign(44, -1);
  cv::Mat d = elas::denseMatching(desc, desc, pts, tris, empty, View::Left, cfg);
  int visited = 0;
  for (int v = 0; v < 40; ++v)
    for (int u = 0; u < 40; ++u) {
      const float x = d.at<float>(v, u);
      CHECK(x == 5.0f || x == elas::kInvalid);
      visited += x == 5.0f;
    }
  CHECK_EQ(visited, 55);
  CHECK_EQ(d.at<float>(10, 10), 5.0f);
  CHECK_EQ(d.at<float>(10, 19), 5.0f);
  CHECK_EQ(d.at<float>(19, 10), 5.0f);
  CHECK_EQ(d.at<float>(10, 20), elas::kInvalid);  // rightmost vertex column excluded
  CHECK_EQ(d.at<float>(20, 10), elas::kInvalid);  // lower edge excluded
  CHECK_EQ(d.at<float>(19, 11), elas::kInvalid);  // v < 30 - 11
}

void testSupportOnShiftedTexture() {
  // Random texture, right image = left shifted by 7 px: the support point and its L/R check find d = 7; the
  // unvisited lattice row 0 / column 0 hold 0.
  Config cfg;
  cfg.dispMax = 31;
  cfg.supportThresholdPercent = 85;
  cfg.supportTexture = 10;
  cfg.supportMinRange = 10;
  cfg.supportMargin = 5;
  cfg.candidateStep = 5;
  cfg.lrThreshold = 2;
  std::mt19937 rng(3);
  cv::Mat left(32, 80, CV_8U), right(32, 80, CV_8U);
  for (int v = 0; v < 32; ++v)
    for (int u = 0; u < 80; ++u) left.at<uint8_t>(v, u) = static_cast<uint8_t>(rng() % 256);
  for (int v = 0; v < 32; ++v)
    for (int u = 0; u < 80; ++u) right.at<uint8_t>(v, u) = left.at<uint8_t>(v, std::min(u + 7, 79));
  const cv::Mat dl = computeDescriptor(left, cfg), dr = computeDescriptor(right, cfg);
  CHECK_EQ(elas::matchSupportPoint(dl, dr, 40, 15, View::Left, cfg), 7);
  CHECK_EQ(elas::matchSupportPoint(dl, dr, 33, 15, View::Right, cfg), 7);
  // Fewer than 11 disparities in range (u - 5 < 10) or inside the 5-pixel margin: no support.
  CHECK_EQ(elas::matchSupportPoint(dl, dr, 14, 15, View::Left, cfg), -1);
  CHECK_EQ(elas::matchSupportPoint(dl, dr, 40, 4, View::Left, cfg), -1);
  const cv::Mat lattice = elas::supportLattice(dl, dr, cfg);
  CHECK_EQ(lattice.rows, 7);
  CHECK_EQ(lattice.cols, 16);
  CHECK_EQ(lattice.at<int16_t>(3, 8), 7);
  CHECK_EQ(lattice.at<int16_t>(0, 8), 0);
  CHECK_EQ(lattice.at<int16_t>(3, 0), 0);
}

void testFlatPairAndErrors() {
  // A flat pair has no texture, hence no support point: every pixel is invalid.
  Config cfg;
  cfg.dispMax = 31;
  cfg.priorTable.clear();
  cv::Mat flat(32, 64, CV_8U, cv::Scalar(100));
  cv::Mat d = elasMatch(flat, flat, cfg);
  CHECK_EQ(d.type(), CV_32F);
  CHECK_EQ(cv::countNonZero(d >= 0), 0);
  CHECK_THROWS(elasMatch(flat, cv::Mat(32, 48, CV_8U, cv::Scalar(0)), cfg), "differ in size");
}

}  // namespace

int main() {
  testInconsistentFilterBorderZeros();
  testRedundantFilter();
  testCornerPoints();
  testPlanes();
  testDelaunay();
  testGridQuirk();
  testRasterisation();
  testSupportOnShiftedTexture();
  testFlatPairAndErrors();
  return testExitCode("test_elas_stages");
}
