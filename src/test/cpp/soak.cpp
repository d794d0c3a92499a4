// The soak run of the IElas top (`make soak`, docs/simulation.md): many frames of random sizes back to back through
// one Verilated model, with random input gaps and output stalls and malformed frames among them.
//
//   ielas_sim soak-plan  writes the frame set: crops of the real pairs in a dataset folder (left and right cut at the
//                        same place) and seeded synthetic pairs as PGM files, and a manifest (one frame a line, with
//                        its malformation, if any). The golden model's disparity.npy of every good frame is added by
//                        scripts/soak.sh.
//   ielas_sim soak       streams the manifest's frames and checks every good frame against its expected .npy, every
//                        malformed frame's flags (errorCauses pulse at its bad beat, frameAborted pulse, the sticky
//                        error bit) and the output framing: a malformed frame's output is whole lines cut without
//                        eof, and every frame after it comes out complete.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "harness.hpp"
#include "ielas/image_io.hpp"
#include "ielas/npy.hpp"

namespace harness {
namespace {

// Seeded draws that do not depend on the standard library's distributions (same plan on every platform).
struct Rng {
  explicit Rng(uint64_t seed) : g(seed) {}
  uint64_t below(uint64_t n) { return n == 0 ? 0 : g() % n; }
  int range(int lo, int hi) { return lo + static_cast<int>(below(static_cast<uint64_t>(hi - lo + 1))); }  // [lo, hi]
  double unit() { return static_cast<double>(g() >> 11) * 0x1.0p-53; }                                  // [0, 1)
  std::mt19937_64 g;
};

// Malformations (FrameGuard.scala). Parameters a, b of the manifest:
//   short  line a ends with eol at column b (b <= W-2)     -> errorCauses bit 1 at that beat
//   long   line a has b extra pixels before its eol (b >= 1) -> bit 2 at column W-1 of line a (no eol there)
//   sof    the frame stops before pixel (b, a), in mid-line (1 <= b <= W-1); the next frame's sof follows
//   trunc  only lines 0..a-1 are sent (1 <= a <= H-1); the next frame's sof follows
//          (sof, trunc)                                    -> bit 3 at the next frame's first beat
enum class Kind { Good, Short, Long, Sof, Trunc };
const char* kKindNames[] = {"good", "short", "long", "sof", "trunc"};
const char* kKindLabels[] = {"good", "short line", "long line", "start of frame in mid-frame", "truncated frame"};
constexpr unsigned kCauseShort = 1u << 1, kCauseLong = 1u << 2, kCauseEarlySof = 1u << 3;

Kind parseKind(const std::string& s) {
  for (int k = 0; k < 5; ++k)
    if (s == kKindNames[k]) return static_cast<Kind>(k);
  throw std::runtime_error("unknown frame kind '" + s + "' (good, short, long, sof, trunc)");
}

std::string joinPath(const std::string& dir, const std::string& p) {
  return p.empty() || p[0] == '/' ? p : dir + "/" + p;
}

void writePgm(const std::string& path, const cv::Mat& img) {
  std::ofstream f(path, std::ios::binary);
  f << "P5\n" << img.cols << " " << img.rows << "\n255\n";
  for (int y = 0; y < img.rows; ++y) f.write(reinterpret_cast<const char*>(img.ptr<uint8_t>(y)), img.cols);
  if (!f) throw std::runtime_error("cannot write " + path);
}

// ----------------------------------------------------------------------------------------------------------------
// soak-plan

const char* kPlanUsage =
    "usage: ielas_sim soak-plan --out DIR [--config NAME|FILE.json] [--frames N] [--seed S] [--data DIR]\n"
    "                           [--malformed-every K] [--synthetic P]\n"
    "  writes DIR/manifest.txt and DIR/frames/*.pgm: N frames (default 200) of random sizes in 32x16..maxWidth x\n"
    "  maxHeight; good frames are crops of the dataset's pairs (--data, default ../shared/data; missing = none) or,\n"
    "  with probability P (default 0.25; 1 without a dataset), seeded synthetic pairs (noise, shifted texture, flat);\n"
    "  frame K/2, K/2+K, ... (K default 10, 0 = none) is malformed, cycling short, long, sof, trunc (never the last)\n";

// The dataset's stereo pairs (left, right), relative to the data folder; missing ones are skipped.
const char* kPairs[][2] = {
    {"kitti2012/training/image_0/000070_10.png", "kitti2012/training/image_1/000070_10.png"},
    {"kitti2015/training/image_2/000046_10.png", "kitti2015/training/image_3/000046_10.png"},
    {"libelas/urban1_left.pgm", "libelas/urban1_right.pgm"},
    {"libelas/urban2_left.pgm", "libelas/urban2_right.pgm"},
    {"libelas/urban3_left.pgm", "libelas/urban3_right.pgm"},
    {"libelas/urban4_left.pgm", "libelas/urban4_right.pgm"},
    {"libelas/aloe_left.pgm", "libelas/aloe_right.pgm"},
    {"libelas/cones_left.pgm", "libelas/cones_right.pgm"},
    {"libelas/raindeer_left.pgm", "libelas/raindeer_right.pgm"},
    {"middlebury/tsukuba/im2.png", "middlebury/tsukuba/im6.png"},
    {"middlebury/venus/im2.png", "middlebury/venus/im6.png"},
    {"middlebury/teddy/im2.png", "middlebury/teddy/im6.png"},
    {"middlebury/cones/im2.png", "middlebury/cones/im6.png"},
    {"middlebury/barn2/im2.png", "middlebury/barn2/im6.png"},
    {"middlebury/bull/im2.png", "middlebury/bull/im6.png"},
    {"middlebury/poster/im2.png", "middlebury/poster/im6.png"},
    {"middlebury/sawtooth/im2.png", "middlebury/sawtooth/im6.png"},
    {"middlebury2006/Cloth3/view1.png", "middlebury2006/Cloth3/view5.png"},
    {"middlebury2006/Reindeer/view1.png", "middlebury2006/Reindeer/view5.png"},
    {"middlebury2006/Wood2/view1.png", "middlebury2006/Wood2/view5.png"},
    {"middlebury2014/trainingQ/Motorcycle/im0.png", "middlebury2014/trainingQ/Motorcycle/im1.png"},
    {"sceneflow_flyingthings3d/RGB_cleanpass/left/A-0032-0006.png",
     "sceneflow_flyingthings3d/RGB_cleanpass/right/A-0032-0006.png"},
};

struct SourcePair {
  std::string name;  // the left image's path in the data folder
  cv::Mat left, right;
};

// A synthetic pair: "noise" (random pixels, right = left shifted by d), "texture" (blurred noise, right = left
// shifted by a disparity that grows down the image), "flat" (one grey level in both views).
void synthesize(Rng& rng, int W, int H, std::string& name, cv::Mat& left, cv::Mat& right) {
  uint64_t pick = rng.below(10);
  left.create(H, W, CV_8U);
  right.create(H, W, CV_8U);
  if (pick == 0) {
    int v = rng.range(0, 255);
    left.setTo(v);
    right.setTo(v);
    name = "flat-" + std::to_string(v);
    return;
  }
  const int dMax = std::min(64, W / 2);
  cv::Mat tex(H, W + dMax, CV_8U);
  for (int y = 0; y < tex.rows; ++y)
    for (int x = 0; x < tex.cols; ++x) tex.at<uint8_t>(y, x) = static_cast<uint8_t>(rng.below(256));
  int d0 = rng.range(0, dMax), d1 = rng.range(0, dMax);
  if (pick <= 4) {
    name = "noise-d" + std::to_string(d0);
    d1 = d0;
  } else {
    cv::Mat blurred;
    cv::GaussianBlur(tex, blurred, cv::Size(0, 0), 1.0 + rng.unit() * 2.0);
    cv::normalize(blurred, tex, 0, 255, cv::NORM_MINMAX);
    name = "texture-d" + std::to_string(d0) + "-" + std::to_string(d1);
  }
  // left(x) = tex(x); right(x) = tex(x + d(y)), so the left pixel x matches the right pixel x - d
  for (int y = 0; y < H; ++y) {
    int d = d0 + (d1 - d0) * y / std::max(1, H - 1);
    for (int x = 0; x < W; ++x) {
      left.at<uint8_t>(y, x) = tex.at<uint8_t>(y, x);
      right.at<uint8_t>(y, x) = tex.at<uint8_t>(y, x + d);
    }
  }
}

}  // namespace

int soakPlanMain(int argc, char** argv) {
  std::string out, config = IELAS_SIM_CONFIG, data = "../shared/data";
  if (const char* env = std::getenv("IELAS_DATA"); env && *env) data = env;
  long frames = 200, every = 10;
  uint64_t seed = 1;
  double synthetic = 0.25;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kPlanUsage, stdout);
      return 0;
    }
    if (i + 1 >= argc) die(1, "soak-plan: option " + a + " needs a value (--help lists the options)");
    std::string v = argv[++i];
    if (a == "--out") out = v;
    else if (a == "--config") config = v;
    else if (a == "--data") data = v;
    else if (a == "--frames") frames = static_cast<long>(parseInt(a, v, 1, 100000));
    else if (a == "--seed") seed = static_cast<uint64_t>(parseInt(a, v, 0, INT64_MAX));
    else if (a == "--malformed-every") every = static_cast<long>(parseInt(a, v, 0, 100000));
    else if (a == "--synthetic") synthetic = v == "1" ? 1.0 : parseProb(a, v);
    else die(1, "soak-plan: unknown option " + a + " (--help lists the options)");
  }
  if (out.empty()) die(1, "soak-plan: --out is required");
  if (config.empty()) die(1, "soak-plan: no configuration: give --config");
  if (every == 1) die(1, "soak-plan: --malformed-every must be 0 or >= 2 (a malformed frame needs a good one after it)");
  int maxW = 0, maxH = 0;
  readConfigSize(config, maxW, maxH);

  std::vector<SourcePair> sources;
  for (const auto& pair : kPairs) {
    std::string l = data + "/" + pair[0], r = data + "/" + pair[1];
    if (!std::filesystem::is_regular_file(l) || !std::filesystem::is_regular_file(r)) continue;
    try {
      SourcePair s{pair[0], ielas::loadGray8(l), ielas::loadGray8(r)};
      if (s.left.size() != s.right.size()) die(1, "soak-plan: " + l + " and " + r + " differ in size");
      sources.push_back(std::move(s));
    } catch (const std::exception& e) {
      die(1, std::string("soak-plan: ") + e.what());
    }
  }
  if (sources.empty()) synthetic = 1.0;

  std::error_code ec;
  std::filesystem::create_directories(out + "/frames", ec);
  if (ec) die(1, "soak-plan: cannot create " + out + "/frames");

  Rng rng(seed);
  // a size in [lo, hi], the ends themselves one time in ten each
  auto size = [&](int lo, int hi) {
    uint64_t r = rng.below(10);
    return r == 0 ? lo : r == 1 ? hi : rng.range(lo, hi);
  };
  std::ostringstream manifest;
  std::map<std::string, int> written;  // frame name -> times used
  long good = 0, malformed = 0, crops = 0, synth = 0;
  for (long i = 0; i < frames; ++i) {
    const int W = size(kMinWidth, maxW), H = size(kMinHeight, maxH);
    Kind kind = Kind::Good;
    if (every > 0 && i % every == every / 2 && i < frames - 1) kind = static_cast<Kind>(1 + malformed % 4);
    // gaps and stalls: none in 3 frames of 10, light in 6, heavy in 1
    auto prob = [&]() {
      uint64_t r = rng.below(10);
      return r < 3 ? 0.0 : r < 9 ? rng.unit() * 0.25 : 0.25 + rng.unit() * 0.35;
    };
    double gap = prob(), stall = prob();
    std::vector<const SourcePair*> fit;
    for (const auto& s : sources)
      if (s.left.cols >= W && s.left.rows >= H) fit.push_back(&s);
    std::string name;
    cv::Mat left, right;
    if (fit.empty() || rng.unit() < synthetic) {
      std::string what;
      synthesize(rng, W, H, what, left, right);
      name = "synth-" + what;
      ++synth;
    } else {
      const SourcePair& s = *fit[rng.below(fit.size())];
      int x0 = rng.range(0, s.left.cols - W), y0 = rng.range(0, s.left.rows - H);
      left = s.left(cv::Rect(x0, y0, W, H)).clone();
      right = s.right(cv::Rect(x0, y0, W, H)).clone();
      name = std::filesystem::path(s.name).replace_extension().string();  // e.g. middlebury_tsukuba_im2-x10y20
      for (const char* drop : {"training/", "trainingQ/", "RGB_cleanpass/"})
        if (auto at = name.find(drop); at != std::string::npos) name.erase(at, std::strlen(drop));
      std::replace(name.begin(), name.end(), '/', '_');
      name += "-x" + std::to_string(x0) + "y" + std::to_string(y0);
      ++crops;
    }
    std::string key = name + "-" + std::to_string(W) + "x" + std::to_string(H);
    if (written.count(key)) key += "-" + std::to_string(i);  // a synthetic pair drawn twice: kept apart
    written[key] = 1;
    try {
      writePgm(out + "/frames/" + key + "_L.pgm", left);
      writePgm(out + "/frames/" + key + "_R.pgm", right);
    } catch (const std::exception& e) {
      die(1, std::string("soak-plan: ") + e.what());
    }
    int a = 0, b = 0;
    switch (kind) {
      case Kind::Good: break;
      case Kind::Short: a = rng.range(0, H - 1), b = rng.range(0, W - 2); break;
      case Kind::Long: a = rng.range(0, H - 1), b = rng.below(4) == 0 ? rng.range(W, 2 * W) : rng.range(1, 64); break;
      case Kind::Sof: a = rng.range(0, H - 1), b = rng.range(1, W - 1); break;
      case Kind::Trunc: a = rng.range(1, H - 1); break;
    }
    if (kind == Kind::Good) ++good;
    else ++malformed;
    char line[600];
    std::snprintf(line, sizeof line, "%ld %s %d %d %.4f %.4f %d %d %s frames/%s_L.pgm frames/%s_R.pgm %s\n", i,
                  kKindNames[static_cast<int>(kind)], W, H, gap, stall, a, b, name.c_str(), key.c_str(), key.c_str(),
                  kind == Kind::Good ? ("golden/" + key + ".npy").c_str() : "-");
    manifest << line;
  }
  std::ofstream f(out + "/manifest.txt");
  f << "# soak plan: configuration " << config << " (max " << maxW << "x" << maxH << "), " << frames
    << " frames, seed " << seed << ", data " << (sources.empty() ? "none" : data) << "\n"
    << "# index kind width height gap stall a b source left right expected (kinds and a, b: src/test/cpp/soak.cpp)\n"
    << manifest.str();
  if (!f) die(1, "soak-plan: cannot write " + out + "/manifest.txt");
  std::printf("soak-plan: %ld frames (%ld good, %ld malformed; %ld dataset crops from %zu pairs, %ld synthetic) -> %s/manifest.txt\n",
              frames, good, malformed, crops, sources.size(), synth, out.c_str());
  return 0;
}

// ----------------------------------------------------------------------------------------------------------------
// soak

namespace {

const char* kSoakUsage =
    "usage: ielas_sim soak --manifest FILE [--config NAME|FILE.json] [--seed S] [--timeout CYCLES] [--progress N]\n"
    "                      [+plusarg ...]\n"
    "  streams the manifest's frames (ielas_sim soak-plan) back to back through one model, each with its own input\n"
    "  gap and output stall probabilities (seeded by S, default 1), and checks every good frame against its\n"
    "  expected .npy and every malformed frame's flags and output. Prints a progress line every N output frames\n"
    "  (default 20). Exit codes: 0 ok, 1 bad input, 2 framing errors (lost or shifted frames among them),\n"
    "  3 timeout (default 4*maxWidth*maxHeight + 100000 cycles without an output transfer), 4 flags wrong (a\n"
    "  malformed frame not flagged, an errorCauses/frameAborted pulse or error bit where none belongs), 5 mismatches\n";

struct Frame {
  long index = 0;
  Kind kind = Kind::Good;
  int W = 0, H = 0;
  double gap = 0, stall = 0;
  int a = 0, b = 0;
  std::string source, left, right, expect;
  // results
  bool causeSeen = false, abortSeen = false;
  long outLines = -2;  // malformed: whole lines put out before the cut (-1: put out whole with eof)
};

struct Beat {
  InBeat in;
  int x, y;        // position in the frame as sent (x may exceed W-1 on a long line)
  unsigned cause;  // the errorCauses pulse this beat must raise when taken
};

std::vector<Frame> readManifest(const std::string& path, int maxW, int maxH) {
  std::ifstream f(path);
  if (!f) die(1, "soak: cannot read manifest " + path);
  std::string dir = std::filesystem::path(path).parent_path().string();
  if (dir.empty()) dir = ".";
  std::vector<Frame> frames;
  std::string line;
  int lineNo = 0;
  while (std::getline(f, line)) {
    ++lineNo;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    Frame fr;
    std::string kind;
    auto bad = [&](const std::string& why) {
      die(1, "soak: manifest " + path + " line " + std::to_string(lineNo) + ": " + why);
    };
    if (!(s >> fr.index >> kind >> fr.W >> fr.H >> fr.gap >> fr.stall >> fr.a >> fr.b >> fr.source >> fr.left >>
          fr.right >> fr.expect))
      bad("expected 12 fields: index kind width height gap stall a b source left right expected");
    try {
      fr.kind = parseKind(kind);
    } catch (const std::exception& e) {
      bad(e.what());
    }
    if (fr.W < kMinWidth || fr.H < kMinHeight || fr.W > maxW || fr.H > maxH)
      bad(std::to_string(fr.W) + "x" + std::to_string(fr.H) + " is outside 32x16.." + std::to_string(maxW) + "x" +
          std::to_string(maxH));
    if (!(fr.gap >= 0 && fr.gap < 1 && fr.stall >= 0 && fr.stall < 1)) bad("gap and stall must lie in [0, 1)");
    bool ok = true;
    switch (fr.kind) {
      case Kind::Good: ok = fr.expect != "-"; break;
      case Kind::Short: ok = fr.a >= 0 && fr.a < fr.H && fr.b >= 0 && fr.b <= fr.W - 2; break;
      case Kind::Long: ok = fr.a >= 0 && fr.a < fr.H && fr.b >= 1; break;
      case Kind::Sof: ok = fr.a >= 0 && fr.a < fr.H && fr.b >= 1 && fr.b <= fr.W - 1; break;
      case Kind::Trunc: ok = fr.a >= 1 && fr.a <= fr.H - 1; break;
    }
    if (!ok) bad("parameters a, b out of range for kind " + kind + " (or a good frame without an expected .npy)");
    fr.left = joinPath(dir, fr.left);
    fr.right = joinPath(dir, fr.right);
    if (fr.kind == Kind::Good) {
      fr.expect = joinPath(dir, fr.expect);
      if (!std::filesystem::is_regular_file(fr.expect)) bad("no expected output " + fr.expect);
    }
    frames.push_back(fr);
  }
  if (frames.empty()) die(1, "soak: manifest " + path + " lists no frames");
  if (frames.back().kind != Kind::Good)
    die(1, "soak: manifest " + path + ": the last frame must be good (a malformed frame is known only by what follows)");
  return frames;
}

// The input beats of frame i as sent, malformation included (see Kind).
std::vector<Beat> frameBeats(const std::vector<Frame>& frames, size_t i) {
  const Frame& f = frames[i];
  cv::Mat left, right;
  try {
    left = ielas::loadGray8(f.left);
    right = ielas::loadGray8(f.right);
  } catch (const std::exception& e) {
    die(1, std::string("soak: ") + e.what());
  }
  if (left.cols != f.W || left.rows != f.H || right.size() != left.size())
    die(1, "soak: frame " + std::to_string(f.index) + ": " + f.left + " is not " + std::to_string(f.W) + "x" +
               std::to_string(f.H) + " (or its right image differs)");
  std::vector<Beat> beats;
  beats.reserve(static_cast<size_t>(f.W) * f.H + (f.kind == Kind::Long ? f.b : 0));
  const int rows = f.kind == Kind::Trunc ? f.a : f.kind == Kind::Sof ? f.a + 1 : f.H;
  for (int y = 0; y < rows; ++y) {
    int len = f.W;
    if (f.kind == Kind::Short && y == f.a) len = f.b + 1;
    if (f.kind == Kind::Long && y == f.a) len = f.W + f.b;
    if (f.kind == Kind::Sof && y == f.a) len = f.b;
    for (int x = 0; x < len; ++x) {
      Beat b;
      b.in.left = left.at<uint8_t>(y, x % f.W);
      b.in.right = right.at<uint8_t>(y, x % f.W);
      b.in.sof = x == 0 && y == 0;
      b.in.eol = x == len - 1 && !(f.kind == Kind::Sof && y == f.a);
      b.x = x, b.y = y;
      b.cause = 0;
      if (f.kind == Kind::Short && y == f.a && x == f.b) b.cause = kCauseShort;
      if (f.kind == Kind::Long && y == f.a && x == f.W - 1) b.cause = kCauseLong;
      beats.push_back(b);
    }
  }
  if (i > 0 && (frames[i - 1].kind == Kind::Sof || frames[i - 1].kind == Kind::Trunc)) beats[0].cause |= kCauseEarlySof;
  return beats;
}

std::string frameName(const Frame& f) {
  return "frame " + std::to_string(f.index) + " (" + kKindNames[static_cast<int>(f.kind)] + " " + std::to_string(f.W) +
         "x" + std::to_string(f.H) + " " + f.source + ")";
}

}  // namespace

int soakMain(int argc, char** argv) {
  std::string manifestPath, config = IELAS_SIM_CONFIG;
  uint64_t seed = 1;
  long long timeoutOpt = -1;
  long progress = 20;
  std::vector<std::string> plusargs;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kSoakUsage, stdout);
      return 0;
    }
    if (!a.empty() && a[0] == '+') {
      plusargs.push_back(a);
      continue;
    }
    if (i + 1 >= argc) die(1, "soak: option " + a + " needs a value (--help lists the options)");
    std::string v = argv[++i];
    if (a == "--manifest") manifestPath = v;
    else if (a == "--config") config = v;
    else if (a == "--seed") seed = static_cast<uint64_t>(parseInt(a, v, 0, INT64_MAX));
    else if (a == "--timeout") timeoutOpt = parseInt(a, v, 1, INT64_MAX);
    else if (a == "--progress") progress = static_cast<long>(parseInt(a, v, 0, 1000000));
    else die(1, "soak: unknown option " + a + " (--help lists the options)");
  }
  if (manifestPath.empty()) die(1, "soak: --manifest is required");
  if (config.empty()) die(1, "soak: no configuration: give --config");
  int maxW = 0, maxH = 0;
  readConfigSize(config, maxW, maxH);
  std::vector<Frame> frames = readManifest(manifestPath, maxW, maxH);
  const size_t F = frames.size();
  std::vector<size_t> malformedIdx;
  long kindCount[5] = {0, 0, 0, 0, 0};
  for (size_t i = 0; i < F; ++i) {
    ++kindCount[static_cast<int>(frames[i].kind)];
    if (frames[i].kind != Kind::Good) malformedIdx.push_back(i);
  }
  const long long timeout = timeoutOpt > 0 ? timeoutOpt : 4LL * maxW * maxH + 100000;
  std::printf("soak: %s, %zu frames (%ld good, %zu malformed), max %dx%d, seed %lu\n", manifestPath.c_str(), F,
              kindCount[0], malformedIdx.size(), maxW, maxH, (unsigned long)seed);
  std::fflush(stdout);

  Dut dut(argv[0], plusargs);
  Rng rng(seed);

  // ---- checks and their counters ----
  const int kShown = 10;
  uint64_t framingErrors = 0, flagErrors = 0, lostOrShifted = 0, mismatches = 0, compared = 0, framesMismatching = 0;
  auto framing = [&](const std::string& what) {
    if (framingErrors < kShown) std::printf("framing error: %s\n", what.c_str());
    ++framingErrors;
  };
  auto flagError = [&](const std::string& what) {
    if (flagErrors < kShown) std::printf("flag error: %s\n", what.c_str());
    ++flagErrors;
  };

  // ---- input side ----
  size_t fi = 0, pos = 0;  // frame and beat being offered
  std::vector<Beat> beats = frameBeats(frames, 0);
  bool inValid = false, inputDone = false;

  // ---- output side: the pixels since the last sof (one output frame or its cut part) ----
  size_t e = 0;  // the input frame the next output frame must belong to
  std::vector<int16_t> chunk;
  std::vector<uint8_t> chunkFlags;  // bit 0 sof, 1 eol, 2 eof
  bool chunkOpen = false;

  auto checkFlags = [&](const Frame& f, bool cut) {
    const size_t n = chunk.size();
    for (size_t p = 0; p < n; ++p) {
      int x = static_cast<int>(p % f.W), y = static_cast<int>(p / f.W);
      unsigned want = (p == 0 ? 1u : 0u) | (x == f.W - 1 ? 2u : 0u) | (!cut && p == n - 1 ? 4u : 0u);
      if (chunkFlags[p] != want) {
        char buf[240];
        std::snprintf(buf, sizeof buf, "%s output pixel (x=%d, y=%d): sof/eol/eof %d%d%d, expected %d%d%d",
                      frameName(f).c_str(), x, y, chunkFlags[p] & 1, (chunkFlags[p] >> 1) & 1, (chunkFlags[p] >> 2) & 1,
                      want & 1, (want >> 1) & 1, (want >> 2) & 1);
        framing(buf);
        return;  // one report per frame
      }
    }
  };

  auto compareGood = [&](Frame& f) {
    const size_t N = static_cast<size_t>(f.W) * f.H;
    if (chunk.size() != N) {
      framing(frameName(f) + ": " + std::to_string(chunk.size()) + " output pixels up to eof, expected " +
              std::to_string(N) + " (frame lost or shifted)");
      ++lostOrShifted;
      return;
    }
    checkFlags(f, false);
    ielas::NpyArray want;
    try {
      want = ielas::readNpy(f.expect);
    } catch (const std::exception& ex) {
      die(1, std::string("soak: ") + ex.what());
    }
    if (want.descr != "<i2" || want.shape != std::vector<int>{f.H, f.W})
      die(1, "soak: " + f.expect + " is not <i2 of shape (" + std::to_string(f.H) + ", " + std::to_string(f.W) + ")");
    uint64_t bad = 0;
    for (size_t p = 0; p < N; ++p) {
      int64_t w = want.value(p);
      if (chunk[p] == w) continue;
      if (bad == 0 && framesMismatching < kShown)
        std::printf("mismatch: %s first at (x=%d, y=%d): hardware %d, expected %lld\n", frameName(f).c_str(),
                    static_cast<int>(p % f.W), static_cast<int>(p / f.W), chunk[p], static_cast<long long>(w));
      ++bad;
    }
    compared += N;
    mismatches += bad;
    if (bad > 0 && ++framesMismatching <= kShown) {
      std::printf("mismatch: %s: %lu of %zu values differ from %s\n", frameName(f).c_str(), (unsigned long)bad, N,
                  f.expect.c_str());
    }
  };

  // A chunk that ended with eof: a good frame (malformed frames before it put out nothing).
  auto closeComplete = [&]() {
    while (e < F && frames[e].kind != Kind::Good) {
      Frame& m = frames[e];
      const size_t mN = static_cast<size_t>(m.W) * m.H;
      const bool nextSameSize = e + 1 < F && static_cast<size_t>(frames[e + 1].W) * frames[e + 1].H == chunk.size();
      if (chunk.size() == mN && !nextSameSize) {
        framing(frameName(m) + ": put out whole with eof, not cut");
        m.outLines = -1;
        ++e;
        return;
      }
      m.outLines = 0;
      ++e;
    }
    if (e >= F) {
      framing("an output frame of " + std::to_string(chunk.size()) + " pixels after the last frame");
      return;
    }
    compareGood(frames[e]);
    ++e;
  };

  // A chunk that a new sof ended without eof: a malformed frame's output, cut after a whole line.
  auto closeCut = [&]() {
    if (e >= F) {
      framing("an output frame part of " + std::to_string(chunk.size()) + " pixels after the last frame");
      return;
    }
    Frame& f = frames[e];
    if (f.kind == Kind::Good) {
      framing(frameName(f) + ": output cut after " + std::to_string(chunk.size()) + " pixels without eof (frame lost or shifted)");
      ++lostOrShifted;
    } else if (chunk.size() % f.W != 0 || chunk.size() > static_cast<size_t>(f.W) * f.H) {
      framing(frameName(f) + ": cut output of " + std::to_string(chunk.size()) + " pixels is not whole lines of " +
              std::to_string(f.W));
    } else {
      checkFlags(f, true);
      f.outLines = static_cast<long>(chunk.size() / f.W);
    }
    ++e;
  };

  auto t0 = std::chrono::steady_clock::now();
  dut.reset(5, frames[0].W, frames[0].H);

  uint64_t cycle = 0, lastOutProgress = 0, firstIn = 0, lastOut = 0;
  bool sawIn = false, expectError = false;
  size_t nextAbort = 0;  // index into malformedIdx of the next frameAborted pulse
  long lastReported = 0;
  while (!(inputDone && e >= F)) {
    if (dut.finished()) die(1, "soak: the model called $finish at cycle " + std::to_string(cycle));
    const Frame& inF = frames[fi];
    if (!inValid && !inputDone) inValid = inF.gap == 0 || rng.unit() >= inF.gap;
    const double stall = e < F ? frames[e].stall : 0.0;
    const bool outReady = stall == 0 || rng.unit() >= stall;
    const Beat& beat = beats[pos];
    Sample s = dut.step(inValid && !inputDone, beat.in, outReady, inF.W, inF.H, true);

    // flags: the errorCauses pulse of a beat comes with its transfer; the error bit follows one cycle later
    if (s.error != expectError)
      flagError("error bit " + std::to_string(s.error) + " at cycle " + std::to_string(cycle) + ", expected " +
                std::to_string(expectError) + " (errorCauses pulses in the cycle before: " +
                (expectError ? "yes" : "none") + ")");
    expectError = s.causes != 0;
    const unsigned wantCause = s.inFire ? beat.cause : 0u;
    if (s.causes != wantCause) {
      char buf[300];
      std::snprintf(buf, sizeof buf, "errorCauses 0x%02x at cycle %lu, expected 0x%02x (input %s, beat (x=%d, y=%d)%s)",
                    s.causes, (unsigned long)cycle, wantCause, frameName(inF).c_str(), beat.x, beat.y,
                    s.inFire ? "" : " not taken");
      flagError(buf);
    } else if (wantCause != 0) {
      if (wantCause & kCauseEarlySof) frames[fi - 1].causeSeen = true;  // the frame this sof cut short
      if (wantCause & (kCauseShort | kCauseLong)) frames[fi].causeSeen = true;
    }
    if (s.aborted) {
      if (nextAbort >= malformedIdx.size()) {
        flagError("frameAborted pulse at cycle " + std::to_string(cycle) + " with no malformed frame left to flag");
      } else {
        Frame& m = frames[malformedIdx[nextAbort]];
        if (!m.causeSeen)
          flagError("frameAborted pulse at cycle " + std::to_string(cycle) + " before the bad beat of the next " +
                    "malformed frame, " + frameName(m) + " (input at " + frameName(inF) + ")");
        m.abortSeen = true;
        ++nextAbort;
      }
    }

    if (s.inFire) {
      if (!sawIn) firstIn = cycle, sawIn = true;
      inValid = false;
      if (++pos == beats.size()) {
        pos = 0;
        if (++fi == F) {
          inputDone = true;
          fi = F - 1;
        } else {
          beats = frameBeats(frames, fi);
        }
      }
    }

    if (s.outFire) {
      lastOut = lastOutProgress = cycle;
      if (s.sof) {
        if (chunkOpen) closeCut();
        chunk.clear();
        chunkFlags.clear();
        chunkOpen = true;
      }
      if (!chunkOpen) {
        framing("output pixel without a frame (no sof since the last eof) at cycle " + std::to_string(cycle));
      } else {
        chunk.push_back(s.data);
        chunkFlags.push_back(static_cast<uint8_t>((s.sof ? 1 : 0) | (s.eol ? 2 : 0) | (s.eof ? 4 : 0)));
        if (s.eof) {
          closeComplete();
          chunkOpen = false;
        } else if (chunk.size() > static_cast<size_t>(maxW) * maxH) {
          framing("an output frame longer than " + std::to_string(maxW) + "x" + std::to_string(maxH) + " pixels");
          closeCut();
          chunkOpen = false;
        }
      }
      if (progress > 0 && static_cast<long>(e) >= lastReported + progress) {
        lastReported = static_cast<long>(e);
        double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::printf("soak: %zu of %zu frames out, cycle %lu, %.0f s, mismatches %lu, framing errors %lu, flag errors %lu\n",
                    e, F, (unsigned long)cycle, wall, (unsigned long)mismatches, (unsigned long)framingErrors,
                    (unsigned long)flagErrors);
        std::fflush(stdout);
      }
    }
    if (static_cast<long long>(cycle - lastOutProgress) > timeout) {
      std::printf("timeout: no output transfer for %lld cycles at cycle %lu (input at %s beat %zu of %zu%s; output "
                  "waiting for frame %zu of %zu)\n",
                  timeout, (unsigned long)cycle, frameName(frames[fi]).c_str(), pos, beats.size(),
                  inputDone ? ", all input sent" : "", e, F);
      die(3, "soak: timeout: no output progress for " + std::to_string(timeout) + " cycles (" + std::to_string(e) +
                 " of " + std::to_string(F) + " frames out)");
    }
    ++cycle;
  }

  // Drain: anything the model still sends after the last frame's eof is a framing error.
  uint64_t extra = 0;
  for (int i = 0; i < 4 * maxW + 1000; ++i) {
    Sample s = dut.step(false, InBeat{}, true, frames.back().W, frames.back().H, true);
    if (s.outFire) ++extra;
    if (s.error != expectError) flagError("error bit " + std::to_string(s.error) + " after the last frame");
    expectError = s.causes != 0;
    if (s.causes != 0 || s.aborted) flagError("errorCauses/frameAborted pulse after the last frame");
  }
  if (extra > 0) framing(std::to_string(extra) + " output pixel(s) after the last frame's eof");
  dut.final();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // ---- malformed frames: flagged (cause pulse and frameAborted pulse) and cut ----
  long flagged = 0, cutOk = 0, minLines = -1, maxLines = -1;
  int shownUnflagged = 0;
  for (size_t i : malformedIdx) {
    const Frame& m = frames[i];
    if (m.causeSeen && m.abortSeen) ++flagged;
    else if (shownUnflagged++ < kShown)
      std::printf("not flagged: %s (%s): errorCauses pulse %s, frameAborted pulse %s\n", frameName(m).c_str(),
                  kKindLabels[static_cast<int>(m.kind)], m.causeSeen ? "yes" : "no", m.abortSeen ? "yes" : "no");
    if (m.outLines >= 0) {
      ++cutOk;
      minLines = minLines < 0 ? m.outLines : std::min(minLines, m.outLines);
      maxLines = std::max(maxLines, m.outLines);
    }
  }
  const long unflagged = static_cast<long>(malformedIdx.size()) - flagged;
  const uint64_t cycles = sawIn ? lastOut - firstIn + 1 : 0;

  std::printf("frames streamed: %zu (%ld good, %zu malformed: %ld short line, %ld long line, %ld sof in mid-frame, "
              "%ld truncated)\n",
              F, kindCount[0], malformedIdx.size(), kindCount[1], kindCount[2], kindCount[3], kindCount[4]);
  std::printf("values compared: %lu\n", (unsigned long)compared);
  std::printf("mismatches: %lu (in %lu frames)\n", (unsigned long)mismatches, (unsigned long)framesMismatching);
  std::printf("malformed frames flagged: %ld of %zu (errorCauses pulse at the bad beat and frameAborted pulse)\n",
              flagged, malformedIdx.size());
  std::printf("malformed frames cut: %ld of %zu (whole lines, no eof; lines put out %ld..%ld)\n", cutOk,
              malformedIdx.size(), minLines, maxLines);
  std::printf("lost or shifted frames: %lu\n", (unsigned long)lostOrShifted);
  std::printf("framing errors: %lu\n", (unsigned long)framingErrors);
  std::printf("flag errors: %lu\n", (unsigned long)flagErrors);
  std::printf("cycles: %lu\n", (unsigned long)cycles);
  std::printf("sim wall time: %.3f s (%lu cycles simulated, %.0f cycles/s)\n", wall, (unsigned long)dut.clocks(),
              dut.clocks() / wall);
  if (framingErrors > 0)
    die(2, "soak: " + std::to_string(framingErrors) + " framing error(s), " + std::to_string(lostOrShifted) +
               " frame(s) lost or shifted");
  if (unflagged > 0 || flagErrors > 0)
    die(4, "soak: " + std::to_string(unflagged) + " malformed frame(s) not flagged, " + std::to_string(flagErrors) +
               " flag error(s)");
  if (mismatches > 0)
    die(5, "soak: " + std::to_string(mismatches) + " of " + std::to_string(compared) + " values differ from the golden model");
  std::printf("soak: passed\n");
  return 0;
}

}  // namespace harness
