// ielas-eval decodes every ground-truth encoding of ../shared/data the way the data's README measured it
// independently (numpy + Pillow): size, smallest and largest valid disparity, fraction of valid pixels. The
// expected values are that README's verification table, printed to 3 (disparity) and 4 (fraction) decimals,
// so a value matches when it rounds to the printed one. Skipped without the shared data.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace {

struct GroundTruth {
  const char* path;
  int width, height;
  double scale, minDisp, maxDisp, validFraction;
};

const GroundTruth kTable[] = {
    {"middlebury/barn2/disp2.png", 430, 381, 8, 3.375, 16.500, 1.0000},
    {"middlebury/bull/disp2.png", 433, 381, 8, 3.625, 19.125, 1.0000},
    {"middlebury/cones/disp2.png", 450, 375, 4, 5.500, 55.000, 0.9678},
    {"middlebury/poster/disp2.png", 435, 383, 8, 3.375, 20.125, 1.0000},
    {"middlebury/sawtooth/disp2.png", 434, 380, 8, 3.875, 17.875, 1.0000},
    {"middlebury/teddy/disp2.png", 450, 375, 4, 12.500, 52.750, 0.9798},
    {"middlebury/tsukuba/disp2.png", 384, 288, 16, 5.000, 14.000, 0.7930},
    {"middlebury/venus/disp2.png", 434, 383, 8, 3.000, 19.750, 1.0000},
    {"middlebury_v2_eval/cones/groundtruth.png", 450, 375, 4, 5.500, 55.000, 0.9678},
    {"middlebury_v2_eval/teddy/groundtruth.png", 450, 375, 4, 12.500, 52.750, 0.9798},
    {"middlebury_v2_eval/tsukuba/groundtruth.png", 384, 288, 16, 5.000, 14.000, 0.7930},  // palette PNG
    {"middlebury_v2_eval/venus/groundtruth.png", 434, 383, 8, 3.000, 19.750, 1.0000},
    {"middlebury2006/Cloth3/disp1.png", 626, 555, 2, 22.500, 83.000, 0.9918},
    {"middlebury2006/Reindeer/disp1.png", 671, 555, 2, 5.500, 100.500, 0.9943},
    {"middlebury2006/Wood2/disp1.png", 653, 555, 2, 21.500, 108.500, 0.9810},
    {"middlebury2014/trainingQ/Motorcycle/disp0GT.pfm", 741, 497, 1, 9.178, 62.877, 0.9791},
    {"kitti2012/training/disp_noc/000070_10.png", 1241, 376, 256, 4.672, 123.035, 0.2878},
    {"kitti2012/training/disp_occ/000070_10.png", 1241, 376, 256, 4.672, 147.020, 0.2941},
    {"kitti2015/training/disp_occ_0/000046_10.png", 1242, 375, 256, 4.871, 65.738, 0.1182},
    {"sceneflow_flyingthings3d/disparity/left/A-0032-0006.pfm", 960, 540, 1, 1.206, 130.365, 1.0000},
};

bool roundsTo(double value, double printed, int decimals) {
  const double unit = std::pow(10.0, -decimals);
  return std::fabs(value - printed) <= unit / 2 + 1e-9;
}

}  // namespace

int main() {
  const std::string data = IELAS_TEST_DATA_DIR;
  struct stat info;
  if (stat(data.c_str(), &info) != 0) {
    std::cout << "test_eval_data: no shared data at " << data << ", skipped\n";
    return 0;
  }
  const std::string tmp = std::string(IELAS_TEST_TMP_DIR) + "/eval_data";
  mkdir(IELAS_TEST_TMP_DIR, 0755);
  mkdir(tmp.c_str(), 0755);
  int failures = 0;
  for (const GroundTruth& t : kTable) {
    const std::string out = tmp + "/gt.pfm";
    const std::string command = std::string(IELAS_BIN_DIR) + "/ielas-eval gt-to-pfm --gt " + data + "/" + t.path +
                                " --gt-scale " + std::to_string(t.scale) + " --out " + out;
    if (std::system(command.c_str()) != 0) {
      std::cerr << t.path << ": ielas-eval failed\n";
      ++failures;
      continue;
    }
    std::ifstream in(out, std::ios::binary);
    std::string magic;
    int w = 0, h = 0;
    double scale = 0;
    in >> magic >> w >> h >> scale;
    in.get();
    std::vector<float> values(static_cast<size_t>(w) * h);
    in.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(values.size() * 4));
    double lo = 1e30, hi = -1e30;
    long valid = 0;
    for (float v : values)
      if (v >= 0) {
        ++valid;
        lo = std::min(lo, static_cast<double>(v));
        hi = std::max(hi, static_cast<double>(v));
      }
    const double fraction = values.empty() ? 0 : static_cast<double>(valid) / values.size();
    if (!in || w != t.width || h != t.height || !roundsTo(lo, t.minDisp, 3) || !roundsTo(hi, t.maxDisp, 3) ||
        !roundsTo(fraction, t.validFraction, 4)) {
      std::cerr << t.path << ": " << w << "x" << h << " min " << lo << " max " << hi << " valid " << fraction
                << ", expected " << t.width << "x" << t.height << " " << t.minDisp << " " << t.maxDisp << " "
                << t.validFraction << "\n";
      ++failures;
    }
  }
  if (failures) {
    std::cerr << "test_eval_data: " << failures << " failure(s)\n";
    return 1;
  }
  std::cout << "test_eval_data: " << sizeof kTable / sizeof kTable[0] << " ground-truth files decoded as documented\n";
  return 0;
}
