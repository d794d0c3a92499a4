// ielas-synth: ground truth at hand-computed pixels, the views agree with it, and the output is deterministic.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "check.hpp"

namespace {

const std::string kBin = std::string(IELAS_BIN_DIR) + "/ielas-synth";
const std::string kTmp = std::string(IELAS_TEST_TMP_DIR) + "/synth";

cv::Mat readPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (!in || magic != "Pf" || scale >= 0) return cv::Mat();
  cv::Mat out(h, w, CV_32F);
  for (int y = h - 1; y >= 0; --y) in.read(reinterpret_cast<char*>(out.ptr<float>(y)), w * 4);
  return in ? out : cv::Mat();
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void checkDisparity(const cv::Mat& disp, int x, int y, double expected, int line) {
  const double got = disp.at<float>(y, x);
  if (got != expected) {
    std::cerr << __FILE__ << ":" << line << ": GT at (" << x << "," << y << ") = " << got << ", expected " << expected
              << "\n";
    recordFailure();
  }
}
#define CHECK_GT(disp, x, y, expected) checkDisparity(disp, x, y, expected, __LINE__)

}  // namespace

int main() {
  mkdir(IELAS_TEST_TMP_DIR, 0755);
  mkdir(kTmp.c_str(), 0755);
  const std::string a = kTmp + "/a", b = kTmp + "/b";
  CHECK(std::system((kBin + " --out " + a + " >/dev/null").c_str()) == 0);
  CHECK(std::system((kBin + " --out " + b + " >/dev/null").c_str()) == 0);

  const cv::Mat disp = readPfm(a + "/disp.pfm");
  const cv::Mat kitti = cv::imread(a + "/disp.png", cv::IMREAD_UNCHANGED);
  const cv::Mat kittiNoc = cv::imread(a + "/disp_noc.png", cv::IMREAD_UNCHANGED);
  const cv::Mat nonocc = cv::imread(a + "/nonocc.png", cv::IMREAD_UNCHANGED);
  const cv::Mat left = cv::imread(a + "/left.png", cv::IMREAD_UNCHANGED);
  const cv::Mat right = cv::imread(a + "/right.png", cv::IMREAD_UNCHANGED);
  const cv::Mat leftPgm = cv::imread(a + "/left.pgm", cv::IMREAD_UNCHANGED);
  CHECK(disp.cols == 640 && disp.rows == 360);
  CHECK(kitti.type() == CV_16U && kitti.size() == disp.size());
  CHECK(left.type() == CV_8U && right.type() == CV_8U && left.size() == disp.size());
  if (anyFailed()) return testExitCode("test_eval_synth");

  // Hand-computed planes at 640x360 (data/README.md lists them):
  CHECK_GT(disp, 470, 225, 88);                 // box: d = 88
  CHECK_GT(disp, 100, 350, 91.875);             // ground: 7/16 * 350 - 61.25
  CHECK_GT(disp, 100, 100, 41.25);              // facade: 60 - 3/16 * 100
  CHECK_GT(disp, 300, 100, 53.4375);            // panel: 30 + 300/16 + 3/64 * 100
  CHECK_GT(disp, 600, 20, 17.375);              // back wall: 8 + 600/64
  CHECK(kitti.at<uint16_t>(350, 100) == 23520); // 91.875 * 256

  // Visibility: the box is seen by both views; the ground at (395, 225) has d = 37.1875, so it maps to
  // x = 357.8 in the right view, inside the box's right-view span [311.5, 452.5): occluded. The ground at
  // (5, 300) has d = 70 and maps outside the right image.
  CHECK(nonocc.at<uint8_t>(225, 470) == 255);
  CHECK(nonocc.at<uint8_t>(225, 395) == 0);
  CHECK(nonocc.at<uint8_t>(300, 5) == 0);
  CHECK(kittiNoc.at<uint16_t>(225, 395) == 0);
  CHECK(kittiNoc.at<uint16_t>(225, 470) == 88 * 256);

  // Every coefficient is a multiple of 1/256: the KITTI PNG is the PFM exactly; disp_noc = disp where visible.
  long pngMismatch = 0, nocMismatch = 0, photoMismatch = 0, photoChecked = 0;
  for (int y = 0; y < disp.rows; ++y)
    for (int x = 0; x < disp.cols; ++x) {
      const double d = disp.at<float>(y, x);
      pngMismatch += kitti.at<uint16_t>(y, x) != d * 256;
      nocMismatch += kittiNoc.at<uint16_t>(y, x) != (nonocc.at<uint8_t>(y, x) ? kitti.at<uint16_t>(y, x) : 0);
      // A visible pixel with an integer disparity sees the same surface point in both views.
      if (nonocc.at<uint8_t>(y, x) && d == std::floor(d)) {
        ++photoChecked;
        photoMismatch += left.at<uint8_t>(y, x) != right.at<uint8_t>(y, x - static_cast<int>(d));
      }
    }
  CHECK(pngMismatch == 0);
  CHECK(nocMismatch == 0);
  CHECK(photoChecked > 20000);  // the box alone has 141 x 151 such pixels
  CHECK(photoMismatch == 0);
  CHECK(cv::countNonZero(left != leftPgm) == 0);

  // Deterministic: a second run writes the same bytes.
  for (const char* file : {"left.png", "right.png", "disp.pfm", "disp.png", "disp_noc.png", "nonocc.png"})
    if (slurp(a + "/" + file) != slurp(b + "/" + file)) {
      std::cerr << "second run differs in " << file << "\n";
      recordFailure();
    }

  // Bad arguments fail.
  CHECK(std::system((kBin + " --out " + kTmp + "/c --width abc 2>/dev/null").c_str()) != 0);
  CHECK(std::system((kBin + " --out " + kTmp + "/c --width 8 2>/dev/null").c_str()) != 0);
  CHECK(std::system((kBin + " 2>/dev/null").c_str()) != 0);

  return testExitCode("test_eval_synth");
}
