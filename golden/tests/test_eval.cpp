// ielas-eval on tiny hand-made maps: every expected number below is computed by hand in the comments.
// The test writes its inputs with its own PFM/NPY writers, runs the binary and parses its CSV line.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "check.hpp"

namespace {

const std::string kBin = std::string(IELAS_BIN_DIR) + "/ielas-eval";
const std::string kTmp = std::string(IELAS_TEST_TMP_DIR) + "/eval";
const float kInf = std::numeric_limits<float>::infinity();

// The CSV prints 4 decimals, so equal within 5e-5 means the hand value was printed.
void checkNear(const std::map<std::string, double>& row, const std::string& column, double expected, int line) {
  auto it = row.find(column);
  if (it == row.end()) {
    std::cerr << __FILE__ << ":" << line << ": no column " << column << "\n";
    recordFailure();
  } else if (!(std::fabs(it->second - expected) <= 5e-5)) {
    std::cerr << __FILE__ << ":" << line << ": " << column << " = " << it->second << ", expected " << expected << "\n";
    recordFailure();
  }
}
#define CHECK_COL(row, column, expected) checkNear(row, column, expected, __LINE__)

void writePfm(const std::string& path, const std::vector<std::vector<float>>& rows) {
  std::ofstream out(path, std::ios::binary);
  out << "Pf\n" << rows[0].size() << " " << rows.size() << "\n-1.0\n";
  for (size_t y = rows.size(); y-- > 0;)  // bottom row first
    out.write(reinterpret_cast<const char*>(rows[y].data()), static_cast<std::streamsize>(rows[y].size() * 4));
}

std::vector<std::vector<float>> readPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  std::vector<std::vector<float>> rows(h, std::vector<float>(w));
  for (int y = h - 1; y >= 0; --y) in.read(reinterpret_cast<char*>(rows[y].data()), w * 4);
  return rows;
}

void writeNpy(const std::string& path, const std::vector<int16_t>& row) {
  std::string header = "{'descr': '<i2', 'fortran_order': False, 'shape': (1, " + std::to_string(row.size()) + "), }";
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::ofstream out(path, std::ios::binary);
  out.write("\x93NUMPY\x01\x00", 8);
  const uint16_t length = static_cast<uint16_t>(header.size());
  out.put(static_cast<char>(length & 0xff));
  out.put(static_cast<char>(length >> 8));
  out << header;
  out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * 2));
}

struct Run {
  int status = 0;
  std::string out, err;
};

Run run(const std::string& args) {
  const std::string outFile = kTmp + "/stdout.txt", errFile = kTmp + "/stderr.txt";
  Run r;
  r.status = std::system((kBin + " " + args + " >" + outFile + " 2>" + errFile).c_str());
  std::ifstream o(outFile), e(errFile);
  std::stringstream so, se;
  so << o.rdbuf();
  se << e.rdbuf();
  r.out = so.str();
  r.err = se.str();
  return r;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream s(line);
  std::string cell;
  while (std::getline(s, cell, ',')) cells.push_back(cell);
  return cells;
}

// Runs `score --header ...` and returns column -> value of its one result line.
std::map<std::string, double> score(const std::string& args) {
  const Run r = run("score --header " + args);
  std::map<std::string, double> row;
  if (r.status != 0) {
    std::cerr << "ielas-eval failed: " << r.err;
    recordFailure();
    return row;
  }
  std::stringstream lines(r.out);
  std::string header, values;
  std::getline(lines, header);
  std::getline(lines, values);
  const auto names = split(header), cells = split(values);
  CHECK(names.size() == cells.size());
  for (size_t i = 2; i < names.size() && i < cells.size(); ++i) row[names[i]] = std::atof(cells[i].c_str());
  return row;
}

int lineCount(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

void testBadKInvalidEpeRel() {
  // GT 10 10 10 10 20 (none); prediction 11 12 13 13.5 invalid 5. Region = the first 5 pixels.
  // Errors 1, 2, 3, 3.5 and one invalid: bad-k needs err > k (strictly), the invalid pixel is bad.
  writePfm(kTmp + "/a_gt.pfm", {{10, 10, 10, 10, 20, kInf}});
  writePfm(kTmp + "/a_disp.pfm", {{11, 12, 13, 13.5f, -1, 5}});
  auto row = score("--disp " + kTmp + "/a_disp.pfm --gt " + kTmp + "/a_gt.pfm");
  CHECK_COL(row, "pixels", 5);
  CHECK_COL(row, "density", 80);      // 4 / 5
  CHECK_COL(row, "bad1", 80);         // (2, 3, 3.5) + invalid = 4 / 5
  CHECK_COL(row, "bad2", 60);         // (3, 3.5) + invalid
  CHECK_COL(row, "bad3", 40);         // (3.5) + invalid
  CHECK_COL(row, "bad1_valid", 75);   // 3 / 4
  CHECK_COL(row, "bad2_valid", 50);   // 2 / 4
  CHECK_COL(row, "bad3_valid", 25);   // 1 / 4
  CHECK_COL(row, "d1", 40);           // 3.5 > 3 and 3.5/10 > 5 %, plus invalid
  CHECK_COL(row, "epe", 2.375);       // (1 + 2 + 3 + 3.5) / 4
  CHECK_COL(row, "rel", 23.75);       // 100 * (0.1 + 0.2 + 0.3 + 0.35) / 4
  CHECK_COL(row, "bad3_ipol", 40);    // the gap takes min(13.5, 5) = 5 against GT 20: still bad
}

void testD1FivePercentRule() {
  // GT 100 100 50; errors 4.5 (4.5 %: not D1), 6 (6 %: D1), 4 (8 %: D1). All three are bad-3.
  writePfm(kTmp + "/b_gt.pfm", {{100, 100, 50}});
  writePfm(kTmp + "/b_disp.pfm", {{104.5f, 106, 54}});
  auto row = score("--disp " + kTmp + "/b_disp.pfm --gt " + kTmp + "/b_gt.pfm");
  CHECK_COL(row, "d1", 200.0 / 3);
  CHECK_COL(row, "bad3", 100);
  CHECK_COL(row, "d1_ipol", 200.0 / 3);
}

void testKittiInterpolation() {
  const float I = -1;
  // Row 0 empty (copies row 1), row 1: left end extended, gap between 10 and 30 takes the smaller (10);
  // row 2: gap between 20 and 40 takes 20, right end extended; row 3 empty between filled rows: stays
  // invalid; row 4 full; row 5 empty at the bottom: copies row 4.
  writePfm(kTmp + "/c_disp.pfm", {{I, I, I, I, I},
                                   {I, 10, I, I, 30},
                                   {20, I, 40, I, I},
                                   {I, I, I, I, I},
                                   {5, 5, 5, 5, 5},
                                   {I, I, I, I, I}});
  const std::vector<std::vector<float>> expected = {{10, 10, 10, 10, 30}, {10, 10, 10, 10, 30}, {20, 20, 40, 40, 40},
                                                    {I, I, I, I, I},       {5, 5, 5, 5, 5},       {5, 5, 5, 5, 5}};
  std::vector<std::vector<float>> gt = expected;
  gt[3] = {7, 7, 7, 7, 7};
  writePfm(kTmp + "/c_gt.pfm", gt);
  auto row = score("--disp " + kTmp + "/c_disp.pfm --gt " + kTmp + "/c_gt.pfm --ipol-out " + kTmp + "/c_ipol.pfm");
  const auto filled = readPfm(kTmp + "/c_ipol.pfm");
  CHECK(filled.size() == 6);
  for (size_t y = 0; y < filled.size() && y < 6; ++y)
    for (size_t x = 0; x < 5; ++x) {
      const float want = expected[y][x];
      const float got = filled[y][x];
      if (!((want < 0 && got < 0) || got == want)) {
        std::cerr << "ipol fill at row " << y << " col " << x << ": " << got << ", expected " << want << "\n";
        recordFailure();
      }
    }
  CHECK_COL(row, "bad1_ipol", 100.0 * 5 / 30);  // only the 5 pixels of the empty middle row
  CHECK_COL(row, "d1_ipol", 100.0 * 5 / 30);
  CHECK_COL(row, "density", 30);                // 2 + 2 + 5 valid of 30
}

void testKittiPngInputs() {
  // Prediction KITTI PNG 10, invalid, 12.5; GT uint16/256: 10, 10, none. Region 2 pixels.
  cv::Mat disp = (cv::Mat_<uint16_t>(1, 3) << 2560, 0, 3200);
  cv::Mat gt = (cv::Mat_<uint16_t>(1, 3) << 2560, 2560, 0);
  cv::imwrite(kTmp + "/d_disp.png", disp);
  cv::imwrite(kTmp + "/d_gt.png", gt);
  auto row = score("--disp " + kTmp + "/d_disp.png --gt " + kTmp + "/d_gt.png --gt-scale 256");
  CHECK_COL(row, "pixels", 2);
  CHECK_COL(row, "density", 50);
  CHECK_COL(row, "bad3", 50);
  CHECK_COL(row, "epe", 0);
}

void testEightBitGtMasksAndNpy() {
  // 8-bit GT / 4: 10, 11, none, 12. Prediction .npy (disparity*16): 10, 15, 5/16, invalid.
  cv::Mat gt = (cv::Mat_<uint8_t>(1, 4) << 40, 44, 0, 48);
  cv::imwrite(kTmp + "/e_gt.png", gt);
  writeNpy(kTmp + "/e_disp.npy", {160, 240, 5, -1});
  cv::Mat keep = (cv::Mat_<uint8_t>(1, 4) << 255, 255, 255, 0);   // --mask: score where 255
  cv::Mat drop = (cv::Mat_<uint8_t>(1, 4) << 0, 255, 0, 0);       // --exclude-mask: skip where non-zero
  cv::imwrite(kTmp + "/e_keep.png", keep);
  cv::imwrite(kTmp + "/e_drop.png", drop);
  const std::string base = "--disp " + kTmp + "/e_disp.npy --gt " + kTmp + "/e_gt.png --gt-scale 4 ";
  auto kept = score(base + "--mask " + kTmp + "/e_keep.png");
  CHECK_COL(kept, "pixels", 2);  // pixels 0 and 1 (pixel 2 has no GT, pixel 3 is masked)
  CHECK_COL(kept, "bad3", 50);   // errors 0 and 4
  CHECK_COL(kept, "epe", 2);
  auto dropped = score(base + "--exclude-mask " + kTmp + "/e_drop.png");
  CHECK_COL(dropped, "pixels", 2);  // pixels 0 and 3
  CHECK_COL(dropped, "density", 50);
  CHECK_COL(dropped, "bad1", 50);   // pixel 3 is invalid
}

void testPicturesAndErrors() {
  const std::string a = "--disp " + kTmp + "/a_disp.pfm --gt " + kTmp + "/a_gt.pfm ";
  Run ok = run("score " + a + "--colour " + kTmp + "/a_colour.png --error " + kTmp + "/a_error.png");
  CHECK(ok.status == 0);
  cv::Mat colour = cv::imread(kTmp + "/a_colour.png"), error = cv::imread(kTmp + "/a_error.png");
  CHECK(colour.cols == 6 && colour.rows == 1);
  CHECK(error.cols == 6 && error.rows == 1);
  if (!error.empty()) CHECK(error.at<cv::Vec3b>(0, 5) == cv::Vec3b(0, 0, 0));  // no GT: black

  // Bad input: a non-zero exit and one line on stderr.
  const std::vector<std::string> bad = {
      "score --disp " + kTmp + "/missing.pfm --gt " + kTmp + "/a_gt.pfm",
      "score --disp " + kTmp + "/b_disp.pfm --gt " + kTmp + "/a_gt.pfm",  // 3 wide against 6 wide
      "score " + a + "--bogus 1",
      "score " + a + "--gt-scale x",
      "frobnicate",
  };
  for (const auto& args : bad) {
    Run r = run(args);
    if (r.status == 0 || lineCount(r.err) != 1) {
      std::cerr << "expected one-line error for: " << args << "\n got status " << r.status << ": " << r.err;
      recordFailure();
    }
  }
}

}  // namespace

int main() {
  mkdir(IELAS_TEST_TMP_DIR, 0755);
  mkdir(kTmp.c_str(), 0755);
  testBadKInvalidEpeRel();
  testD1FivePercentRule();
  testKittiInterpolation();
  testKittiPngInputs();
  testEightBitGtMasksAndNpy();
  testPicturesAndErrors();
  return testExitCode("test_eval");
}
