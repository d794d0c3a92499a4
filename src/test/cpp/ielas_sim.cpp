// Verilator testbench for the IElas top: streams a left/right pair (N frames back to back) through the model and
// reports cycles, cycles/pixel, fps at an assumed 200 MHz clock, latency in rows, the error bit and framing problems. It writes the
// last frame's output as OUT/disparity.npy (<i2, (H, W), disparity*16, -1 invalid) and OUT/cycles.txt.
//
// Cycle numbering: cycle 0 is the first clock edge after reset; a transfer "at cycle c" is sampled at that edge.
// cycles = last output transfer - first input transfer + 1, over all frames.
// Exit codes: 0 ok, 1 bad input or usage, 2 framing errors (sof/eol/eof in the wrong place, output beyond the
// last frame), 3 timeout (no output transfer for --timeout cycles), 4 the hardware raised its error bit,
// 5 --expect given and the last frame's output differs from it.
// Usage: see usage() below; docs/simulation.md has the details.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "harness.hpp"
#include "ielas/image_io.hpp"
#include "ielas/npy.hpp"

namespace {

using harness::die;
using harness::parseInt;
using harness::parseProb;

const char* kUsage =
    "usage: ielas_sim --left L --right R --out DIR [--config NAME|FILE.json | --max-width W --max-height H]\n"
    "                 [--frames N] [--gaps P] [--stalls P] [--seed S] [--timeout CYCLES] [--expect D.npy] [--images]\n"
    "                 [+plusarg ...]\n"
    "       ielas_sim soak-plan ... | ielas_sim soak ...   (the soak run, `make soak`; --help of each)\n"
    "  --config      configuration whose maxWidth/maxHeight bound the frame (default: the one built: '" IELAS_SIM_CONFIG
    "')\n"
    "  --frames N    stream the pair N times back to back (1..10000, default 1); the last frame's output is written\n"
    "  --gaps P      probability of an idle input cycle (seeded; default 0)\n"
    "  --stalls P    probability of output back-pressure in a cycle (seeded; default 0)\n"
    "  --timeout C   fail (exit 3) after C cycles without an output transfer (default 2*W*H/(1-P) + 100000)\n"
    "  --expect F    compare the last frame's output with F (<i2, (H, W), e.g. the golden disparity.npy):\n"
    "                prints 'mismatches: N' and the first mismatch; exit 5 when N > 0\n"
    "  --images      also write OUT/disparity.pfm and OUT/disparity_kitti.png (KITTI uint16, disparity*256)\n"
    "  --row-cycles  also write OUT/row_cycles.csv: per frame and row, the cycles of its last input and output pixel\n"
    "  +...          passed to the Verilated model ($value$plusargs)\n";

struct Options {
  std::string left, right, out, expect, config = IELAS_SIM_CONFIG;
  int maxWidth = 0, maxHeight = 0;
  long frames = 1;
  double gaps = 0, stalls = 0;
  uint64_t seed = 1;
  long long timeout = -1;
  bool images = false;
  bool rowCycles = false;
  std::vector<std::string> plusargs;
};

Options parseArgs(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    if (a == "--row-cycles") {
      o.rowCycles = true;
      continue;
    }
    if (a == "--images") {
      o.images = true;
      continue;
    }
    if (!a.empty() && a[0] == '+') {
      o.plusargs.push_back(a);
      continue;
    }
    if (i + 1 >= argc) die(1, "option " + a + " needs a value (--help lists the options)");
    std::string v = argv[++i];
    if (a == "--left") o.left = v;
    else if (a == "--right") o.right = v;
    else if (a == "--out") o.out = v;
    else if (a == "--config") o.config = v;
    else if (a == "--expect") o.expect = v;
    else if (a == "--max-width") o.maxWidth = static_cast<int>(parseInt(a, v, 32, 8192));
    else if (a == "--max-height") o.maxHeight = static_cast<int>(parseInt(a, v, 16, 8192));
    else if (a == "--frames") o.frames = static_cast<long>(parseInt(a, v, 1, 10000));  // per-row cycle records: 16 bytes a row
    else if (a == "--gaps") o.gaps = parseProb(a, v);
    else if (a == "--stalls") o.stalls = parseProb(a, v);
    else if (a == "--seed") o.seed = static_cast<uint64_t>(parseInt(a, v, 0, INT64_MAX));
    else if (a == "--timeout") o.timeout = parseInt(a, v, 1, INT64_MAX);
    else die(1, "unknown option " + a + " (--help lists the options)");
  }
  if (o.left.empty() || o.right.empty() || o.out.empty()) die(1, "--left, --right and --out are required");
  if ((o.maxWidth == 0) != (o.maxHeight == 0)) die(1, "give both --max-width and --max-height, or neither");
  if (o.maxWidth == 0 && o.config.empty()) die(1, "no configuration: give --config or --max-width/--max-height");
  return o;
}

struct Report {
  uint64_t firstIn = 0, lastOut = 0;
  bool sawIn = false;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "soak-plan") return harness::soakPlanMain(argc - 1, argv + 1);
  if (argc > 1 && std::string(argv[1]) == "soak") return harness::soakMain(argc - 1, argv + 1);
  Options o = parseArgs(argc, argv);
  int maxW = o.maxWidth, maxH = o.maxHeight;
  if (maxW == 0) harness::readConfigSize(o.config, maxW, maxH);

  cv::Mat left, right;
  try {
    left = ielas::loadGray8(o.left);
    right = ielas::loadGray8(o.right);
    ielas::checkPairSize(left, right, maxW, maxH, o.config.empty() ? "--max-width/--max-height" : "configuration " + o.config);
  } catch (const std::exception& e) {
    die(1, e.what());
  }
  const int W = left.cols, H = left.rows;
  // Read the expected output before simulating, so a bad file fails fast.
  ielas::NpyArray expected;
  if (!o.expect.empty()) {
    try {
      expected = ielas::readNpy(o.expect);
    } catch (const std::exception& e) {
      die(1, e.what());
    }
    if (expected.descr != "<i2" || expected.shape != std::vector<int>{H, W})
      die(1, "--expect " + o.expect + " is not <i2 of shape (" + std::to_string(H) + ", " + std::to_string(W) + ")");
  }
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec || !std::filesystem::is_directory(o.out)) die(1, "cannot create output directory " + o.out);

  const uint64_t N = static_cast<uint64_t>(W) * H;
  const uint64_t F = static_cast<uint64_t>(o.frames);
  const uint64_t inTotal = N * F;
  const long long timeout =
      o.timeout > 0 ? o.timeout : static_cast<long long>(2.0 * N / (1.0 - o.gaps)) + 100000;

  std::printf("ielas_sim: %dx%d (max %dx%d), %lu frame(s), gaps %.3g, stalls %.3g, seed %lu\n", W, H, maxW, maxH,
              (unsigned long)F, o.gaps, o.stalls, (unsigned long)o.seed);
  std::fflush(stdout);

  harness::Dut dut(argv[0], o.plusargs);

  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);

  std::vector<int16_t> lastFrame(N, 0);
  std::vector<uint64_t> inRowLast(F * H, 0), outRowLast(F * H, 0);
  uint64_t inIdx = 0, outIdx = 0, cycle = 0, lastOutProgress = 0;
  uint64_t framingErrors = 0;
  Report rep;
  bool inValid = false;
  const int kShownErrors = 10;

  auto framing = [&](const std::string& what) {
    if (framingErrors < kShownErrors) std::printf("framing error: %s\n", what.c_str());
    ++framingErrors;
  };

  auto t0 = std::chrono::steady_clock::now();

  dut.reset(5, W, H);

  // One clock cycle: drive the next pixel (offered until taken), sample the handshakes, then the rising edge.
  auto step = [&](bool driveInput, bool& inFire, bool& outFire, int16_t& data, bool& sof, bool& eol, bool& eof) {
    if (driveInput && !inValid && inIdx < inTotal) inValid = o.gaps == 0 || uni(rng) >= o.gaps;
    uint64_t p = inIdx % N;
    int x = static_cast<int>(p % W), y = static_cast<int>(p / W);
    harness::InBeat beat;
    beat.left = left.at<uint8_t>(y, x);
    beat.right = right.at<uint8_t>(y, x);
    beat.sof = p == 0;
    beat.eol = x == W - 1;
    bool outReady = o.stalls == 0 || uni(rng) >= o.stalls;
    harness::Sample s = dut.step(inValid, beat, outReady, W, H);
    inFire = s.inFire;
    outFire = s.outFire;
    data = s.data;
    sof = s.sof;
    eol = s.eol;
    eof = s.eof;
  };

  while (outIdx < inTotal) {
    if (dut.finished()) die(1, "the model called $finish at cycle " + std::to_string(cycle));
    bool inFire, outFire, sof, eol, eof;
    int16_t data;
    step(true, inFire, outFire, data, sof, eol, eof);
    if (inFire) {
      if (!rep.sawIn) rep.firstIn = cycle, rep.sawIn = true;
      uint64_t p = inIdx % N;
      if (p % W == static_cast<uint64_t>(W - 1)) inRowLast[inIdx / W] = cycle;
      ++inIdx;
      inValid = false;
    }
    if (outFire) {
      uint64_t f = outIdx / N, p = outIdx % N;
      int x = static_cast<int>(p % W), y = static_cast<int>(p / W);
      bool wantSof = p == 0, wantEol = x == W - 1, wantEof = p == N - 1;
      if (sof != wantSof || eol != wantEol || eof != wantEof) {
        char buf[200];
        std::snprintf(buf, sizeof buf, "frame %lu output pixel (x=%d, y=%d): sof/eol/eof %d%d%d, expected %d%d%d",
                      (unsigned long)f, x, y, sof, eol, eof, wantSof, wantEol, wantEof);
        framing(buf);
      }
      if (f == F - 1) lastFrame[p] = data;
      if (wantEol) outRowLast[outIdx / W] = cycle;
      rep.lastOut = cycle;
      lastOutProgress = cycle;
      ++outIdx;
    }
    if (static_cast<long long>(cycle - lastOutProgress) > timeout) {
      std::printf("timeout: no output transfer for %lld cycles at cycle %lu (%lu of %lu pixels in, %lu out)\n",
                  timeout, (unsigned long)cycle, (unsigned long)inIdx, (unsigned long)inTotal, (unsigned long)outIdx);
      std::fflush(stdout);
      die(3, "timeout: no output progress for " + std::to_string(timeout) + " cycles (" + std::to_string(outIdx) +
                 " of " + std::to_string(inTotal) + " output pixels)");
    }
    ++cycle;
  }

  // Drain: anything the model still sends after the last frame's last pixel is a framing error.
  uint64_t extra = 0;
  for (int i = 0; i < W + 64; ++i) {
    bool inFire, outFire, sof, eol, eof;
    int16_t data;
    step(false, inFire, outFire, data, sof, eol, eof);
    if (outFire) ++extra;
  }
  if (extra > 0) framing(std::to_string(extra) + " output pixel(s) after the last frame's last pixel");
  const bool errorBit = dut.error();
  dut.final();
  double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const uint64_t cycles = rep.lastOut - rep.firstIn + 1;
  uint64_t latencyRows = 0;
  for (uint64_t r = 0; r < F * H; ++r) {
    uint64_t d = outRowLast[r] > inRowLast[r] ? outRowLast[r] - inRowLast[r] : 0;
    latencyRows = std::max<uint64_t>(latencyRows, (d + W - 1) / W);
  }

  try {
    ielas::writeNpy(o.out + "/disparity.npy", "<i2", {H, W}, lastFrame.data());
    FILE* c = std::fopen((o.out + "/cycles.txt").c_str(), "w");
    if (!c) throw std::runtime_error("cannot write " + o.out + "/cycles.txt");
    std::fprintf(c, "%lu\n", (unsigned long)cycles);
    std::fclose(c);
    if (o.rowCycles) {  // where the input waits: a row whose last input comes more than W cycles after the previous
      FILE* r = std::fopen((o.out + "/row_cycles.csv").c_str(), "w");
      if (!r) throw std::runtime_error("cannot write " + o.out + "/row_cycles.csv");
      std::fprintf(r, "frame,row,last_input_cycle,last_output_cycle\n");
      for (uint64_t i = 0; i < F * H; ++i)
        std::fprintf(r, "%lu,%lu,%lu,%lu\n", (unsigned long)(i / H), (unsigned long)(i % H), (unsigned long)inRowLast[i],
                     (unsigned long)outRowLast[i]);
      std::fclose(r);
    }
    if (o.images) {
      cv::Mat d(H, W, CV_32F);  // output format: disparity*16, negative = invalid
      for (uint64_t i = 0; i < N; ++i)
        d.at<float>(static_cast<int>(i / W), static_cast<int>(i % W)) = lastFrame[i] < 0 ? -1.0f : lastFrame[i] / 16.0f;
      ielas::writePfm(o.out + "/disparity.pfm", d);
      ielas::writeKittiPng(o.out + "/disparity_kitti.png", d);
    }
  } catch (const std::exception& e) {
    die(1, e.what());
  }

  uint64_t mismatches = 0;
  if (!o.expect.empty()) {
    for (uint64_t i = 0; i < N; ++i) {
      int64_t want = expected.value(i);
      if (lastFrame[i] == want) continue;
      if (mismatches == 0)
        std::printf("first mismatch: disparity.npy (x=%d, y=%d) hardware %d, expected %lld\n", static_cast<int>(i % W),
                    static_cast<int>(i / W), lastFrame[i], static_cast<long long>(want));
      ++mismatches;
    }
    std::printf("mismatches: %lu\n", (unsigned long)mismatches);
  }
  double cpp = static_cast<double>(cycles) / static_cast<double>(inTotal);
  std::printf("cycles: %lu\n", (unsigned long)cycles);
  std::printf("cycles/pixel: %.3f\n", cpp);
  std::printf("fps@200MHz: %.1f (assumed clock, not measured: docs/timing.md)\n", 200e6 / (cpp * static_cast<double>(N)));
  std::printf("latency rows: %lu\n", (unsigned long)latencyRows);
  std::printf("error: %d\n", errorBit ? 1 : 0);
  std::printf("framing errors: %lu\n", (unsigned long)framingErrors);
  std::printf("sim wall time: %.3f s (%lu cycles simulated, %.0f cycles/s)\n", wall, (unsigned long)dut.clocks(),
              dut.clocks() / wall);
  std::printf("wrote %s/disparity.npy, %s/cycles.txt%s\n", o.out.c_str(), o.out.c_str(),
              o.images ? ", disparity.pfm, disparity_kitti.png" : "");
  if (framingErrors > 0) die(2, std::to_string(framingErrors) + " framing error(s)");
  if (errorBit) die(4, "the hardware's error bit is set");
  if (mismatches > 0) die(5, std::to_string(mismatches) + " of " + std::to_string(N) + " values differ from " + o.expect);
  return 0;
}
