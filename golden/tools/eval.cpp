// ielas-eval: scores one disparity map against ground truth the way docs/evaluation.md defines it, and
// helps scripts/eval.sh with the file chores (centred crops, colourised maps).
//
//   ielas-eval score --disp D.pfm|D.png|D.npy --gt G.pfm|G.png [--gt-scale S] [--mask M.png]
//                    [--exclude-mask M.png] [--name PAIR] [--region LABEL] [--time SECONDS] [--header]
//                    [--colour C.png] [--error E.png] [--colour-max N (default: GT maximum)]
//                    [--ipol-out F.pfm]
//   ielas-eval header
//   ielas-eval crop --in F --out G --width W --height H      (centred window; PNG kept bit for bit, PFM too)
//   ielas-eval colour --disp D --out C.png [--colour-max N]
//   ielas-eval gt-to-pfm --gt G [--gt-scale S] [--add K] --out F.pfm   (GT as a fake prediction, for tests)
//   ielas-eval size FILE                                               (prints "W H")
//
// Disparity inputs: PFM (negative, inf or NaN = invalid); KITTI PNG (uint16, value/256, 0 = invalid);
// the golden model's disparity.npy (int16 disparity*16, negative = invalid).
// Ground truth: PFM (non-finite or negative = none); 16-bit PNG (value/gt-scale, default 256); 8-bit PNG,
// palette or grey or RGB with equal channels, read as grey (value/gt-scale), 0 = none.
// Region = pixels with GT, minus pixels where --mask is not 255, minus pixels where --exclude-mask is non-zero.
// Output: one CSV line (columns in csvHeader) on stdout.
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// Every bad input ends the program through this: main prints "ielas-eval: <what>" and exits 1.
struct EvalError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string lowerExtension(const std::string& path) {
  size_t dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// ---------------------------------------------------------------- PFM
// Returns a CV_32F map in top-to-bottom row order. Colour PFMs ("PF") keep their first channel.
cv::Mat readPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw EvalError("cannot read " + path);
  std::string magic;
  int width = 0, height = 0;
  double scale = 0;
  in >> magic >> width >> height >> scale;
  if (!in || (magic != "Pf" && magic != "PF") || width <= 0 || height <= 0 || scale == 0)
    throw EvalError("malformed PFM header in " + path);
  in.get();  // the single whitespace byte before the raster
  const int channels = magic == "PF" ? 3 : 1;
  std::vector<float> raster(static_cast<size_t>(width) * height * channels);
  in.read(reinterpret_cast<char*>(raster.data()), static_cast<std::streamsize>(raster.size() * sizeof(float)));
  if (!in) throw EvalError("truncated PFM raster in " + path);
  const bool fileLittle = scale < 0;
  const uint16_t probe = 1;
  const bool hostLittle = *reinterpret_cast<const uint8_t*>(&probe) == 1;
  if (fileLittle != hostLittle) {
    for (float& v : raster) {
      uint8_t* b = reinterpret_cast<uint8_t*>(&v);
      std::swap(b[0], b[3]);
      std::swap(b[1], b[2]);
    }
  }
  cv::Mat out(height, width, CV_32F);
  for (int y = 0; y < height; ++y) {
    const float* src = &raster[static_cast<size_t>(height - 1 - y) * width * channels];  // stored bottom row first
    float* dst = out.ptr<float>(y);
    for (int x = 0; x < width; ++x) dst[x] = src[x * channels];
  }
  return out;
}

void writePfm(const std::string& path, const cv::Mat& map) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw EvalError("cannot write " + path);
  out << "Pf\n" << map.cols << " " << map.rows << "\n-1.0\n";
  for (int y = map.rows - 1; y >= 0; --y)
    out.write(reinterpret_cast<const char*>(map.ptr<float>(y)), static_cast<std::streamsize>(map.cols * sizeof(float)));
  if (!out) throw EvalError("cannot write " + path);
}

// ---------------------------------------------------------------- NPY (int16, the golden model's disparity.npy)
cv::Mat readNpyInt16(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw EvalError("cannot read " + path);
  char magic[8];
  in.read(magic, 8);
  if (!in || std::memcmp(magic, "\x93NUMPY", 6) != 0) throw EvalError("not an .npy file: " + path);
  size_t headerLength = 0;
  if (magic[6] == 1) {
    uint8_t b[2];
    in.read(reinterpret_cast<char*>(b), 2);
    headerLength = b[0] | (b[1] << 8);
  } else {
    uint8_t b[4];
    in.read(reinterpret_cast<char*>(b), 4);
    headerLength = b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<size_t>(b[3]) << 24);
  }
  std::string header(headerLength, ' ');
  in.read(&header[0], static_cast<std::streamsize>(headerLength));
  if (!in) throw EvalError("truncated .npy header in " + path);
  if (header.find("'<i2'") == std::string::npos || header.find("'fortran_order': False") == std::string::npos)
    throw EvalError("expected a C-order <i2 .npy in " + path);
  size_t open = header.find('('), close = header.find(')');
  int rows = 0, cols = 0;
  if (open == std::string::npos || close == std::string::npos ||
      std::sscanf(header.c_str() + open, "(%d, %d)", &rows, &cols) != 2 || rows <= 0 || cols <= 0)
    throw EvalError("expected a 2-D .npy in " + path);
  cv::Mat out(rows, cols, CV_16S);
  in.read(reinterpret_cast<char*>(out.data), static_cast<std::streamsize>(out.total() * 2));
  if (!in) throw EvalError("truncated .npy data in " + path);
  return out;
}

// ---------------------------------------------------------------- loading maps
// Predicted disparity as CV_32F with every invalid pixel set to -1.
cv::Mat loadPrediction(const std::string& path) {
  const std::string ext = lowerExtension(path);
  cv::Mat disp;
  if (ext == ".pfm") {
    disp = readPfm(path);
  } else if (ext == ".png") {
    cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (raw.empty()) throw EvalError("cannot read " + path);
    if (raw.depth() != CV_16U || raw.channels() != 1)
      throw EvalError("disparity PNG must be 16-bit grey (KITTI format): " + path);
    raw.convertTo(disp, CV_32F, 1.0 / 256.0);
    disp.setTo(-1.0f, raw == 0);
  } else if (ext == ".npy") {
    cv::Mat raw = readNpyInt16(path);
    raw.convertTo(disp, CV_32F, 1.0 / 16.0);
    disp.setTo(-1.0f, raw < 0);
  } else {
    throw EvalError("unknown disparity format (want .pfm, .png or .npy): " + path);
  }
  for (int y = 0; y < disp.rows; ++y) {
    float* row = disp.ptr<float>(y);
    for (int x = 0; x < disp.cols; ++x)
      if (!std::isfinite(row[x]) || row[x] < 0) row[x] = -1.0f;
  }
  return disp;
}

// Ground truth as CV_32F, invalid = -1. An 8-bit PNG is read as grey: palette and equal-channel RGB PNGs
// turn into their grey level (libpng's rgb_to_gray keeps R when R = G = B).
cv::Mat loadGroundTruth(const std::string& path, double scale) {
  const std::string ext = lowerExtension(path);
  cv::Mat gt;
  if (ext == ".pfm") {
    gt = readPfm(path);
    for (int y = 0; y < gt.rows; ++y) {
      float* row = gt.ptr<float>(y);
      for (int x = 0; x < gt.cols; ++x)
        if (!std::isfinite(row[x]) || row[x] < 0) row[x] = -1.0f;
    }
    return gt;
  }
  if (ext != ".png") throw EvalError("unknown ground-truth format (want .pfm or .png): " + path);
  if (!(scale > 0)) throw EvalError("--gt-scale must be positive");
  cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw EvalError("cannot read " + path);
  if (raw.depth() == CV_16U) {
    if (raw.channels() != 1) throw EvalError("16-bit ground truth must be single channel: " + path);
  } else if (raw.depth() == CV_8U) {
    raw = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } else {
    throw EvalError("unsupported ground-truth PNG depth: " + path);
  }
  raw.convertTo(gt, CV_32F, 1.0 / scale);
  gt.setTo(-1.0f, raw == 0);
  return gt;
}

cv::Mat loadMask(const std::string& path) {
  cv::Mat mask = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (mask.empty()) throw EvalError("cannot read mask " + path);
  return mask;
}

// ---------------------------------------------------------------- KITTI devkit background fill
// Each row gap takes the smaller of its two neighbours, row ends are extended, then every column extends its
// first/last valid value up/down (so empty top and bottom rows copy the nearest row). Invalid = -1.
cv::Mat kittiInterpolate(const cv::Mat& disp) {
  cv::Mat out = disp.clone();
  const int width = out.cols, height = out.rows;
  for (int y = 0; y < height; ++y) {
    float* row = out.ptr<float>(y);
    int gap = 0;
    for (int x = 0; x < width; ++x) {
      if (row[x] >= 0) {
        if (gap > 0 && x - gap > 0) {
          const float fill = std::min(row[x - gap - 1], row[x]);
          for (int g = x - gap; g < x; ++g) row[g] = fill;
        }
        gap = 0;
      } else {
        ++gap;
      }
    }
    int first = 0;
    while (first < width && row[first] < 0) ++first;
    if (first == width) continue;  // empty row: left to the column pass
    for (int x = 0; x < first; ++x) row[x] = row[first];
    int last = width - 1;
    while (row[last] < 0) --last;
    for (int x = last + 1; x < width; ++x) row[x] = row[last];
  }
  for (int x = 0; x < width; ++x) {
    int first = 0;
    while (first < height && out.at<float>(first, x) < 0) ++first;
    if (first == height) continue;
    for (int y = 0; y < first; ++y) out.at<float>(y, x) = out.at<float>(first, x);
    int last = height - 1;
    while (out.at<float>(last, x) < 0) --last;
    for (int y = last + 1; y < height; ++y) out.at<float>(y, x) = out.at<float>(last, x);
  }
  return out;
}

// ---------------------------------------------------------------- metrics
struct Scores {
  long pixels = 0;  // region size
  long valid = 0;   // region pixels with a valid prediction
  long badValid[4] = {0, 0, 0, 0};  // index k = 1..3: valid predictions with |err| > k
  long d1Valid = 0;
  long badIpol[4] = {0, 0, 0, 0};
  long d1Ipol = 0;
  double sumErr = 0, sumRel = 0;
  long relCount = 0;
};

// KITTI's D1 outlier: more than 3 px and more than 5 % of the true disparity.
bool isD1Outlier(double err, double gt) { return err > 3.0 && err / std::fabs(gt) > 0.05; }

Scores score(const cv::Mat& disp, const cv::Mat& gt, const cv::Mat& region) {
  const cv::Mat filled = kittiInterpolate(disp);
  Scores s;
  for (int y = 0; y < gt.rows; ++y) {
    const float* d = disp.ptr<float>(y);
    const float* f = filled.ptr<float>(y);
    const float* g = gt.ptr<float>(y);
    const uint8_t* r = region.ptr<uint8_t>(y);
    for (int x = 0; x < gt.cols; ++x) {
      if (!r[x]) continue;
      ++s.pixels;
      if (f[x] >= 0) {
        const double err = std::fabs(static_cast<double>(f[x]) - g[x]);
        for (int k = 1; k <= 3; ++k) s.badIpol[k] += err > k;
        s.d1Ipol += isD1Outlier(err, g[x]);
      } else {
        for (int k = 1; k <= 3; ++k) ++s.badIpol[k];  // rows left empty by the fill stay bad
        ++s.d1Ipol;
      }
      if (d[x] < 0) continue;
      ++s.valid;
      const double err = std::fabs(static_cast<double>(d[x]) - g[x]);
      for (int k = 1; k <= 3; ++k) s.badValid[k] += err > k;
      s.d1Valid += isD1Outlier(err, g[x]);
      s.sumErr += err;
      if (g[x] > 0) {
        s.sumRel += err / g[x];
        ++s.relCount;
      }
    }
  }
  return s;
}

const char* csvHeader =
    "pair,region,pixels,density,bad1,bad2,bad3,bad1_valid,bad2_valid,bad3_valid,d1,"
    "bad1_ipol,bad2_ipol,bad3_ipol,d1_ipol,epe,rel,time_s";

double percent(long part, long whole) { return whole > 0 ? 100.0 * part / whole : std::nan(""); }

std::string csvLine(const std::string& pair, const std::string& region, const Scores& s, double timeSeconds) {
  const long invalid = s.pixels - s.valid;
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "%s,%s,%ld,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f",
                pair.c_str(), region.c_str(), s.pixels, percent(s.valid, s.pixels),
                percent(s.badValid[1] + invalid, s.pixels), percent(s.badValid[2] + invalid, s.pixels),
                percent(s.badValid[3] + invalid, s.pixels), percent(s.badValid[1], s.valid),
                percent(s.badValid[2], s.valid), percent(s.badValid[3], s.valid),
                percent(s.d1Valid + invalid, s.pixels), percent(s.badIpol[1], s.pixels),
                percent(s.badIpol[2], s.pixels), percent(s.badIpol[3], s.pixels), percent(s.d1Ipol, s.pixels),
                s.valid > 0 ? s.sumErr / s.valid : std::nan(""),
                s.relCount > 0 ? 100.0 * s.sumRel / s.relCount : std::nan(""), timeSeconds);
  return buf;
}

// ---------------------------------------------------------------- pictures
// Disparity 0..maxDisp on OpenCV's JET ramp (near = red), invalid = black.
cv::Mat colourise(const cv::Mat& disp, double maxDisp) {
  if (!(maxDisp > 0)) {
    double lo = 0, hi = 0;
    cv::minMaxLoc(disp, &lo, &hi);
    maxDisp = hi > 0 ? hi : 1;
  }
  cv::Mat grey(disp.size(), CV_8U);
  for (int y = 0; y < disp.rows; ++y)
    for (int x = 0; x < disp.cols; ++x)
      grey.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(disp.at<float>(y, x) * 255.0 / maxDisp);
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_JET);
  colour.setTo(cv::Scalar(0, 0, 0), disp < 0);
  return colour;
}

// Per region pixel: green shades for |err| <= 1, 2, 3; orange for up to 5; red beyond; magenta for an
// invalid prediction. Pixels outside the region are black.
cv::Mat errorImage(const cv::Mat& disp, const cv::Mat& gt, const cv::Mat& region) {
  cv::Mat out(gt.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x) {
      if (!region.at<uint8_t>(y, x)) continue;
      const float d = disp.at<float>(y, x);
      cv::Vec3b& px = out.at<cv::Vec3b>(y, x);
      if (d < 0) {
        px = cv::Vec3b(255, 0, 255);
        continue;
      }
      const double err = std::fabs(static_cast<double>(d) - gt.at<float>(y, x));
      if (err <= 1) px = cv::Vec3b(60, 200, 60);
      else if (err <= 2) px = cv::Vec3b(40, 150, 40);
      else if (err <= 3) px = cv::Vec3b(30, 100, 30);
      else if (err <= 5) px = cv::Vec3b(0, 140, 255);
      else px = cv::Vec3b(0, 0, 230);
    }
  return out;
}

void writePng(const std::string& path, const cv::Mat& image) {
  if (!cv::imwrite(path, image)) throw EvalError("cannot write " + path);
}

// ---------------------------------------------------------------- command line
struct Args {
  std::map<std::string, std::string> values;
  bool header = false;
  bool has(const std::string& key) const { return values.count(key) != 0; }
  std::string get(const std::string& key) const {
    auto it = values.find(key);
    if (it == values.end()) throw EvalError("missing " + key);
    return it->second;
  }
  std::string get(const std::string& key, const std::string& fallback) const {
    return has(key) ? values.at(key) : fallback;
  }
  double number(const std::string& key, double fallback) const {
    if (!has(key)) return fallback;
    const std::string& text = values.at(key);
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0') throw EvalError("not a number for " + key + ": " + text);
    return v;
  }
};

Args parseArgs(int argc, char** argv, int first, const std::vector<std::string>& known) {
  Args args;
  for (int i = first; i < argc; ++i) {
    const std::string key = argv[i];
    if (key == "--header") {
      args.header = true;
      continue;
    }
    bool ok = false;
    for (const auto& k : known) ok = ok || k == key;
    if (!ok) throw EvalError("unknown option " + key);
    if (i + 1 >= argc) throw EvalError("missing value after " + key);
    args.values[key] = argv[++i];
  }
  return args;
}

int runScore(const Args& args) {
  const cv::Mat disp = loadPrediction(args.get("--disp"));
  const cv::Mat gt = loadGroundTruth(args.get("--gt"), args.number("--gt-scale", 256.0));
  if (disp.size() != gt.size())
    throw EvalError("disparity is " + std::to_string(disp.cols) + "x" + std::to_string(disp.rows) +
                    " but ground truth is " + std::to_string(gt.cols) + "x" + std::to_string(gt.rows));
  cv::Mat region = gt >= 0;
  if (args.has("--mask")) {
    const cv::Mat mask = loadMask(args.get("--mask"));
    if (mask.size() != gt.size()) throw EvalError("mask size differs from ground truth: " + args.get("--mask"));
    region &= mask == 255;
  }
  if (args.has("--exclude-mask")) {
    const cv::Mat mask = loadMask(args.get("--exclude-mask"));
    if (mask.size() != gt.size())
      throw EvalError("exclude mask size differs from ground truth: " + args.get("--exclude-mask"));
    region &= mask == 0;
  }
  const Scores s = score(disp, gt, region);
  if (s.pixels == 0) throw EvalError("the region holds no ground-truth pixel");
  if (args.header) std::cout << csvHeader << "\n";
  std::cout << csvLine(args.get("--name", "pair"), args.get("--region", "all"), s, args.number("--time", 0.0))
            << std::endl;
  if (args.has("--colour")) {
    double gtMax = 0;  // default scale: the largest true disparity, so every run of a pair shares one scale
    cv::minMaxLoc(gt, nullptr, &gtMax);
    writePng(args.get("--colour"), colourise(disp, args.number("--colour-max", gtMax)));
  }
  if (args.has("--error")) writePng(args.get("--error"), errorImage(disp, gt, region));
  if (args.has("--ipol-out")) writePfm(args.get("--ipol-out"), kittiInterpolate(disp));
  return 0;
}

int runCrop(const Args& args) {
  const std::string in = args.get("--in"), out = args.get("--out");
  const int width = static_cast<int>(args.number("--width", 0)), height = static_cast<int>(args.number("--height", 0));
  if (width <= 0 || height <= 0) throw EvalError("crop needs positive --width and --height");
  const bool pfm = lowerExtension(in) == ".pfm";
  if (pfm != (lowerExtension(out) == ".pfm")) throw EvalError("crop keeps the format: " + in + " -> " + out);
  const cv::Mat image = pfm ? readPfm(in) : cv::imread(in, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw EvalError("cannot read " + in);
  if (image.cols < width || image.rows < height)
    throw EvalError(in + " is smaller than " + std::to_string(width) + "x" + std::to_string(height));
  const cv::Rect window((image.cols - width) / 2, (image.rows - height) / 2, width, height);
  const cv::Mat cropped = image(window).clone();
  if (pfm) writePfm(out, cropped);
  else writePng(out, cropped);
  return 0;
}

// Ground truth rewritten as a prediction PFM (invalid = -1), optionally offset: a known input for checking scripts.
int runGtToPfm(const Args& args) {
  cv::Mat gt = loadGroundTruth(args.get("--gt"), args.number("--gt-scale", 256.0));
  const float offset = static_cast<float>(args.number("--add", 0.0));
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x)
      if (gt.at<float>(y, x) >= 0) gt.at<float>(y, x) = std::max(0.0f, gt.at<float>(y, x) + offset);
  writePfm(args.get("--out"), gt);
  return 0;
}

// "W H" of an image or PFM, for the scripts' size checks.
int runSize(const std::string& path) {
  const cv::Mat image = lowerExtension(path) == ".pfm" ? readPfm(path) : cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw EvalError("cannot read " + path);
  std::cout << image.cols << " " << image.rows << "\n";
  return 0;
}

int runColour(const Args& args) {
  writePng(args.get("--out"), colourise(loadPrediction(args.get("--disp")), args.number("--colour-max", 0.0)));
  return 0;
}

void usage() {
  std::cerr << "usage: ielas-eval score --disp D --gt G [--gt-scale S] [--mask M] [--exclude-mask M] [--name N]\n"
               "                        [--region R] [--time S] [--header] [--colour C.png] [--error E.png]\n"
               "                        [--colour-max N] [--ipol-out F.pfm]\n"
               "       ielas-eval header\n"
               "       ielas-eval crop --in F --out G --width W --height H\n"
               "       ielas-eval colour --disp D --out C.png [--colour-max N]\n"
               "       ielas-eval gt-to-pfm --gt G [--gt-scale S] [--add K] --out F.pfm\n"
               "       ielas-eval size FILE\n";
}

}  // namespace

int main(int argc, char** argv) {
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);  // errors are ours, one line each
  try {
    if (argc < 2) {
      usage();
      return 2;
    }
    const std::string command = argv[1];
    if (command == "score")
      return runScore(parseArgs(argc, argv, 2,
                                {"--disp", "--gt", "--gt-scale", "--mask", "--exclude-mask", "--name", "--region",
                                 "--time", "--colour", "--error", "--colour-max", "--ipol-out"}));
    if (command == "header") {
      std::cout << csvHeader << "\n";
      return 0;
    }
    if (command == "crop") return runCrop(parseArgs(argc, argv, 2, {"--in", "--out", "--width", "--height"}));
    if (command == "colour") return runColour(parseArgs(argc, argv, 2, {"--disp", "--out", "--colour-max"}));
    if (command == "size") {
      if (argc != 3) throw EvalError("size takes one file");
      return runSize(argv[2]);
    }
    if (command == "gt-to-pfm")
      return runGtToPfm(parseArgs(argc, argv, 2, {"--gt", "--gt-scale", "--add", "--out"}));
    if (command == "-h" || command == "--help") {
      usage();
      return 0;
    }
    throw EvalError("unknown command " + command + " (score, header, crop, colour, gt-to-pfm, size)");
  } catch (const EvalError& e) {
    std::cerr << "ielas-eval: " << e.what() << std::endl;
    return 1;
  } catch (const cv::Exception& e) {
    std::cerr << "ielas-eval: OpenCV: " << e.err << std::endl;
    return 1;
  }
}
