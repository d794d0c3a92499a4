// scripts/eval.sh end to end with a stand-in for `ielas-golden match` that answers every pair with its own
// ground truth plus 1.5 px. Expected, by construction: every region pixel with a prediction is off by exactly
// 1.5, so bad-1 = 100 %, bad-2 = bad-3 = 0 over valid predictions, EPE = 1.5. Needs ../shared/data (skipped
// without it).
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

const std::string kTmp = std::string(IELAS_TEST_TMP_DIR) + "/eval_script";
const std::string kRepo = std::string(IELAS_TEST_CONFIG_DIR) + "/../..";

// The stand-in: finds the left view's ground truth from the data layout and writes it back, shifted.
const char* kFakeMatch = R"FAKE(#!/usr/bin/env bash
while [ $# -gt 0 ]; do case "$1" in --left) L="$2"; shift;; --out) O="$2"; shift;; esac; shift; done
d=$(dirname "$L")
case "$L" in
  *image_0*) G="${L/image_0/disp_noc}"; S=256;;
  *image_2*) G="${L/image_2/disp_occ_0}"; S=256;;
  */middlebury/*) G="$d/disp2.png"; case "$L" in *tsukuba*) S=16;; *teddy*|*cones*) S=4;; *) S=8;; esac;;
  *middlebury_v2_eval*) G="$d/groundtruth.png"; S=$(head -1 "$d/info.txt");;
  *middlebury2006*) G="$d/disp1.png"; S=2;;
  *Motorcycle/im0*) G="$d/disp0GT.pfm"; S=1;;
  *RGB_cleanpass*) G="${L/RGB_cleanpass/disparity}"; G="${G%.png}.pfm"; S=1;;
  *-left.png) G="${L%-left.png}-gt.png"; S=2; [ -f "$G" ] || { G="${L%-left.png}-gt.pfm"; S=1; };;
  *) echo "no ground truth for $L" >&2; exit 1;;
esac
"$IELAS_EVAL" gt-to-pfm --gt "$G" --gt-scale "$S" --add 1.5 --out "$O" && echo "time per frame: 12.5 ms"
)FAKE";

std::vector<std::vector<std::string>> readCsv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream s(line);
    std::string cell;
    while (std::getline(s, cell, ',')) cells.push_back(cell);
    rows.push_back(cells);
  }
  return rows;
}

int column(const std::vector<std::string>& header, const std::string& name) {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  std::cerr << "no column " << name << "\n";
  recordFailure();
  return 0;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int runEval(const std::string& args, const std::string& out) {
  const std::string env = "IELAS_DATA=" + std::string(IELAS_TEST_DATA_DIR) + " IELAS_GOLDEN=" + kTmp +
                          "/fake-match.sh IELAS_EVAL=" + IELAS_BIN_DIR + "/ielas-eval EVAL_OUT=" + out;
  return std::system((env + " " + kRepo + "/scripts/eval.sh " + args + " >" + out + ".log 2>&1").c_str());
}

}  // namespace

int main() {
  struct stat info;
  if (stat(IELAS_TEST_DATA_DIR, &info) != 0) {
    std::cout << "test_eval_script: no shared data at " << IELAS_TEST_DATA_DIR << ", skipped\n";
    return 0;
  }
  mkdir(IELAS_TEST_TMP_DIR, 0755);
  mkdir(kTmp.c_str(), 0755);
  {
    std::ofstream fake(kTmp + "/fake-match.sh");
    fake << kFakeMatch;
  }
  chmod((kTmp + "/fake-match.sh").c_str(), 0755);

  // Preset run: all 26 pair/region rows of docs/evaluation.md's table.
  const std::string presetOut = kTmp + "/preset";
  CHECK(runEval("elas --preset robotics", presetOut) == 0);
  auto rows = readCsv(presetOut + "/results.csv");
  CHECK(rows.size() == 27);
  if (!rows.empty()) {
    const auto& h = rows[0];
    const int region = column(h, "region"), family = column(h, "family"), bad1 = column(h, "bad1"),
              bad2v = column(h, "bad2_valid"), bad3v = column(h, "bad3_valid"), epe = column(h, "epe"),
              time = column(h, "time_s");
    for (size_t i = 1; i < rows.size(); ++i) {
      const auto& r = rows[i];
      if (r.size() != h.size()) {
        recordFailure();
        continue;
      }
      CHECK(std::atof(r[bad1].c_str()) == 100.0);
      CHECK(std::atof(r[bad2v].c_str()) == 0.0);
      CHECK(std::atof(r[bad3v].c_str()) == 0.0);
      CHECK(std::fabs(std::atof(r[epe].c_str()) - 1.5) < 1e-4);
      CHECK(std::atof(r[time].c_str()) == 0.0125);  // "12.5 ms" read from the stand-in's output
      (void)region;
      (void)family;
    }
  }
  const std::string md = slurp(presetOut + "/results.md");
  CHECK(md.find("goal mean bad-3: 0.00") != std::string::npos);
  CHECK(md.find("| MBV2 | noc | 4 |") != std::string::npos);

  // A 640x480 configuration: larger pairs are skipped and listed, the three centred crops are scored.
  const std::string configOut = kTmp + "/config";
  CHECK(runEval("ielas --config tsukuba", configOut) == 0);
  const std::string configMd = slurp(configOut + "/results.md");
  CHECK(configMd.find("- kitti2012-000070 (1241x376 > 640x480)") != std::string::npos);
  CHECK(configMd.find("| MB06-crop | all | 2 |") != std::string::npos);
  CHECK(configMd.find("| MB14Q-crop | noc | 1 |") != std::string::npos);

  // Bad invocations fail with a message.
  CHECK(runEval("elas", kTmp + "/bad1") != 0);
  CHECK(runEval("nomode --preset robotics", kTmp + "/bad2") != 0);

  if (anyFailed()) std::cerr << "logs in " << kTmp << "\n";
  return testExitCode("test_eval_script");
}
