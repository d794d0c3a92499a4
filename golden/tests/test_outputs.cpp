// Output formats (PFM, KITTI PNG) by hand, and invariants of the early stages on a real crop cut at test time.
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <sys/stat.h>

#include <opencv2/imgcodecs.hpp>

#include "check.hpp"
#include "ielas/config.hpp"
#include "ielas/ielas.hpp"
#include "ielas/image_io.hpp"
#include "ielas/support.hpp"

using namespace ielas;

namespace {

std::string tmpDir() {
  std::string d = IELAS_TEST_TMP_DIR;
  mkdir(d.c_str(), 0777);
  return d;
}

std::string floatBytes(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, 4);
  std::string s;
  for (int k = 0; k < 4; ++k) s.push_back(static_cast<char>((bits >> (8 * k)) & 0xff));
  return s;
}

void testPfm() {
  cv::Mat d = (cv::Mat_<float>(2, 2) << 1.5f, -10.0f, 0.0f, 2.0f);
  const std::string path = tmpDir() + "/out.pfm";
  writePfm(path, d);
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Header, then the bottom row first; an invalid value is written as -1.
  std::string expected = "Pf\n2 2\n-1.0\n" + floatBytes(0.0f) + floatBytes(2.0f) + floatBytes(1.5f) + floatBytes(-1.0f);
  CHECK(bytes == expected);
  cv::Mat back = readPfm(path);
  CHECK_EQ(back.at<float>(0, 0), 1.5f);
  CHECK_EQ(back.at<float>(1, 1), 2.0f);
}

void testKittiPng() {
  cv::Mat d = (cv::Mat_<float>(1, 4) << 1.5f, -1.0f, 0.0f, 255.9375f);
  const std::string path = tmpDir() + "/out.png";
  writeKittiPng(path, d);
  cv::Mat png = cv::imread(path, cv::IMREAD_UNCHANGED);
  CHECK_EQ(png.type(), CV_16U);
  CHECK_EQ(png.at<uint16_t>(0, 0), 384);    // 1.5 * 256
  CHECK_EQ(png.at<uint16_t>(0, 1), 0);      // invalid
  CHECK_EQ(png.at<uint16_t>(0, 2), 1);      // a valid 0 must not read as invalid
  CHECK_EQ(png.at<uint16_t>(0, 3), 65520);  // 255.9375 * 256
}

// Invariants that hold for any input (not values produced by the code under test).
void testRealCropInvariants() {
  const std::string left = std::string(IELAS_TEST_DATA_DIR) + "/kitti2012/training/image_0/000070_10.png";
  const std::string right = std::string(IELAS_TEST_DATA_DIR) + "/kitti2012/training/image_1/000070_10.png";
  std::ifstream probe(left);
  if (!probe.good()) {
    std::cout << "test_outputs: shared data not found, real-crop checks skipped" << std::endl;
    return;
  }
  Config cfg = loadConfig("small");
  // A 128x64 crop near the horizon (rows 150..213, columns 500..627, disparities within 0..31), cut here.
  cv::Mat l = loadGray8(left)(cv::Rect(500, 150, 128, 64)).clone();
  cv::Mat r = loadGray8(right)(cv::Rect(500, 150, 128, 64)).clone();
  IelasFrame f = runIelas(l, r, cfg);
  CHECK_EQ(f.support.rows, 14);
  CHECK_EQ(f.support.cols, 27);
  int supports = 0, kept = 0;
  for (int j = 0; j < f.support.rows; ++j)
    for (int i = 0; i < f.support.cols; ++i) {
      const int s = f.support.at<int16_t>(j, i), fl = f.filtered.at<int16_t>(j, i), lat = f.lattice.at<int16_t>(j, i);
      CHECK(s >= -1 && s <= cfg.dispMax);
      if (s >= 0) {
        ++supports;
        CHECK(latticeNodeMatchable(i, 128, cfg) && latticeNodeMatchable(j, 64, cfg));
        CHECK(i * 5 - s >= 5);  // the target column respects the support margin
      }
      CHECK(fl == -1 || fl == s);  // the filter only removes
      if (fl >= 0) {
        ++kept;
        CHECK_EQ(lat, fl);  // supports keep their value in the fill
      }
      CHECK(lat >= 0 && lat <= cfg.dispMax);
    }
  CHECK(supports > 10);  // a textured crop has supports; if this fails the stage is broken, not the data
  CHECK(kept > 0);
  for (const Grid* g : {&f.gridL, &f.gridR}) {
    CHECK_EQ(g->rows, 4);
    CHECK_EQ(g->cols, 7);
    for (int gy = 0; gy < g->rows; ++gy)
      for (int gx = 0; gx < g->cols; ++gx)
        for (int k = 0; k < g->slots; ++k) {
          const int d = g->at(gy, gx, k);
          CHECK(d >= -1 && d <= cfg.dispMax);
          if (k > 0 && d >= 0) CHECK(g->at(gy, gx, k - 1) >= 0 && g->at(gy, gx, k - 1) < d);  // ascending, packed
        }
  }
  // Every filtered point's d is in its own left cell.
  for (int j = 0; j < f.filtered.rows; ++j)
    for (int i = 0; i < f.filtered.cols; ++i) {
      const int d = f.filtered.at<int16_t>(j, i);
      if (d < 0) continue;
      const int gy = cfg.latticeCoord(j, 64) / cfg.gridSize, gx = cfg.latticeCoord(i, 128) / cfg.gridSize;
      bool found = false;
      for (int k = 0; k < f.gridL.slots; ++k) found = found || f.gridL.at(gy, gx, k) == d;
      // Only a full cell may have dropped it (the cap keeps the smallest values).
      CHECK(found || f.gridL.at(gy, gx, f.gridL.slots - 1) >= 0);
    }
}

}  // namespace

int main() {
  testPfm();
  testKittiPng();
  testRealCropInvariants();
  return testExitCode("test_outputs");
}
