// Dense matching on a tiny synthetic descriptor image: prior addition, candidate order / tie-break, texture
// skip, border rule, right view. Expected values are computed by hand in the comments.
#include <algorithm>
#include <vector>
#include "check.hpp"
#include "ielas/dense.hpp"

using namespace ielas;

namespace {

constexpr int W = 21, H = 11;  // lattice columns 0..20 step 5, rows 0, 5, 10
constexpr int U = 12, V = 4;   // the reference pixel under test

Config tinyConfig() {
  Config c;
  c.candidateStep = 5;
  c.gridSize = 20;
  c.dispMax = 7;
  c.planeRadius = 2;
  c.matchTexture = 1;
  c.descriptorMargin = 3;
  c.priorTable = {-14, -9, -2, 0, 0, 0, 0, 0};
  return c;
}

Grid grid(std::vector<int> candidates) {
  Grid g;
  g.rows = 1;
  g.cols = 2;
  g.slots = 4;
  g.d.assign(8, -1);
  for (int c = 0; c < 2; ++c)
    for (size_t k = 0; k < candidates.size(); ++k) g.at(0, c, int(k)) = int16_t(candidates[k]);
  return g;
}

cv::Mat descImage(uint8_t value) {
  cv::Mat m(H, W, CV_8UC(16));
  for (int v = 0; v < H; ++v) std::fill(m.ptr<uint8_t>(v), m.ptr<uint8_t>(v) + 16 * W, value);
  return m;
}

void setDesc(cv::Mat& desc, int u, int v, int byte0) {
  uint8_t* p = desc.ptr<uint8_t>(v) + 16 * u;
  for (int k = 0; k < 16; ++k) p[k] = 100;
  p[0] = uint8_t(byte0);
}

// Left descriptor at (U,V) is 100 everywhere; right descriptor at U-d has byte 0 = 100 + sad[d].
int matchLeftOn(const std::vector<int>& sad, const std::vector<int>& candidates, const Config& cfg, const cv::Mat& lat) {
  cv::Mat descL = descImage(0), descR = descImage(0);
  setDesc(descL, U, V, 100);
  for (int d = 0; d <= 7; ++d) setDesc(descR, U - d, V, 100 + sad[size_t(d)]);
  Planes planes = computePlanes(lat, W, H, cfg);
  return denseMatch(descL, descR, planes, grid(candidates), View::Left, cfg).at<int16_t>(V, U);
}

int matchLeft(const std::vector<int>& sad, const std::vector<int>& candidates, const Config& cfg, int latticeValue) {
  cv::Mat descL = descImage(0), descR = descImage(0);
  setDesc(descL, U, V, 100);
  for (int d = 0; d <= 7; ++d) setDesc(descR, U - d, V, 100 + sad[size_t(d)]);
  cv::Mat lat(3, 5, CV_16S, cv::Scalar(latticeValue));
  Planes planes = computePlanes(lat, W, H, cfg);
  cv::Mat out = denseMatch(descL, descR, planes, grid(candidates), View::Left, cfg);
  return out.at<int16_t>(V, U);
}

}  // namespace

int main() {
  Config cfg = tinyConfig();
  // Plane d_p = 3 (flat lattice, valid): range 1..5 with priors P[|d-3|] = -2, -9, -14, -9, -2.
  // SAD: d3 = 4 -> E = -10; d4 = 0 -> E = -9. The prior makes d = 3 win.
  {
    std::vector<int> sad = {50, 50, 50, 4, 0, 50, 50, 50};
    CHECK_EQ(matchLeft(sad, {}, cfg, 3), 3);
    Config noPrior = cfg;
    noPrior.priorTable.assign(8, 0);
    CHECK_EQ(matchLeft(sad, {}, noPrior, 3), 4);  // SAD alone
  }
  // Invalid plane: pixel (12,4) lies in triangle 1 of cell (0,2) (2*5 + 4*5 >= 25) whose bottom edge rises
  // 3 -> 8 over 5 px (a = 1: invalid) and d_p = 3 + 2*1 = 5; range 3..7 is searched without the prior.
  // SAD d5 = 4, d6 = 0: with the prior (flat lattice at 5) E(5) = -10 < E(6) = -9 -> 5; without it -> 6.
  {
    std::vector<int> sad = {50, 50, 50, 50, 50, 4, 0, 50};
    CHECK_EQ(matchLeft(sad, {}, cfg, 5), 5);
    cv::Mat lat(3, 5, CV_16S, cv::Scalar(3));
    lat.at<int16_t>(0, 3) = 8;
    lat.at<int16_t>(1, 3) = 8;
    Planes planes = computePlanes(lat, W, H, cfg);
    CHECK(!planes.left[(0 * 4 + 2) * 2 + 1].valid);
    CHECK_EQ(planeValue(planes.left[(0 * 4 + 2) * 2 + 1], U, V), 5);
    CHECK_EQ(matchLeftOn(sad, {}, cfg, lat), 6);
  }
  // Tie-break: grid candidates outside the range come first, ascending, then the range; strict "<".
  // Grid {0, 7}: E(0) = 20, E(7) = 20; range: E(1) = 22 + P[2] = 20, E(2) = 40 - 9, E(3) = 40 - 14, ...
  {
    std::vector<int> sad = {20, 22, 40, 40, 40, 40, 40, 20};
    CHECK_EQ(matchLeft(sad, {0, 7}, cfg, 3), 0);
    sad[0] = 21;  // now 7 (grid, evaluated before the range) ties with d = 1 and wins
    CHECK_EQ(matchLeft(sad, {0, 7}, cfg, 3), 7);
    // A grid candidate inside the range is evaluated with the range (with its prior), not twice.
    std::vector<int> sad2 = {40, 40, 40, 10, 40, 40, 40, 40};
    CHECK_EQ(matchLeft(sad2, {3}, cfg, 3), 3);
  }
  // Plane at d_p = 0: range clipped to 0..2. E(0) = 20 - 14 = 6, grid candidate E(6) = 3 -> 6.
  {
    std::vector<int> sad = {20, 30, 30, 30, 30, 30, 3, 30};
    CHECK_EQ(matchLeft(sad, {6}, cfg, 0), 6);
    CHECK_EQ(matchLeft(sad, {}, cfg, 0), 0);  // without the grid only 0..2 are searched
  }
  // Texture skip, border rule and target columns outside [m, W-1-m].
  {
    cv::Mat descL = descImage(128), descR = descImage(128);
    cv::Mat lat(3, 5, CV_16S, cv::Scalar(3));
    Planes planes = computePlanes(lat, W, H, cfg);
    cv::Mat out = denseMatch(descL, descR, planes, grid({}), View::Left, cfg);
    CHECK_EQ(out.at<int16_t>(V, U), -1);  // texture 0 < 1
    setDesc(descL, 2, V, 100);
    setDesc(descL, 4, V, 100);
    out = denseMatch(descL, descR, planes, grid({}), View::Left, cfg);
    CHECK_EQ(out.at<int16_t>(V, 2), -1);  // u < m = 3
    CHECK_EQ(out.at<int16_t>(0, 10), -1);  // v < m
    // u = 4, d_p = 3, range 1..5: the target 4 - d must be >= m = 3, so only d = 1 is evaluated.
    CHECK_EQ(out.at<int16_t>(V, 4), 1);
  }
  // Right view: reference right descriptor at (u, V), target left at u + d.
  {
    cv::Mat descL = descImage(0), descR = descImage(0);
    const int u = 6;
    setDesc(descR, u, V, 100);
    for (int d = 0; d <= 7; ++d) setDesc(descL, u + d, V, d == 5 ? 100 : 140);
    cv::Mat lat(3, 5, CV_16S, cv::Scalar(4));
    Planes planes = computePlanes(lat, W, H, cfg);
    cv::Mat out = denseMatch(descL, descR, planes, grid({}), View::Right, cfg);
    // range 2..6: E(5) = 0 - 9 = -9, E(4) = 40 - 14 = 26 -> 5.
    CHECK_EQ(out.at<int16_t>(V, u), 5);
  }
  CHECK_THROWS(denseMatch(cv::Mat(2, 2, CV_8UC(16)), cv::Mat(2, 2, CV_8UC(16)),
                          computePlanes(cv::Mat(3, 5, CV_16S, cv::Scalar(0)), W, H, cfg), grid({}), View::Left, cfg),
               "descriptors must be");
  return testExitCode("test_dense");
}
