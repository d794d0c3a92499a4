// ielas-synth: a deterministic synthetic stereo scene with exact ground truth (the project's own data; what
// `make run` uses when ../shared/data is missing). See data/README.md.
//
//   ielas-synth --out DIR [--width 640] [--height 360] [--noise SIGMA] [--seed N]
//
// The scene is a set of planar patches, each given in left-image coordinates as a disparity plane
// d(x, y) = a x + b y + c over a rectangle: a back wall slanted in x, a ground plane rising towards the camera,
// a facade receding to the right, a tilted panel, and a fronto-parallel box in front (d = 88). A plane in
// disparity space is a plane in 3-D, and the nearest surface is the one with the largest disparity, so both
// views are exact renderings of one scene. Each patch carries a smooth procedural texture fixed to the
// surface (indexed by the left-image coordinates of the surface point), so the right view shows the same
// texture at x_right = x - d. All plane coefficients are multiples of 1/256 at 640x360: the KITTI PNG holds
// the same values as the PFM.
//
// Writes: left.png right.png (8-bit grey), left.pgm right.pgm (the same pixels), disp.pfm (left-view GT,
// every pixel), disp.png (KITTI uint16 = d*256), disp_noc.png (occluded pixels 0), nonocc.png (255 = visible in
// both views, 0 = occluded or out of the right view).
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace {

struct SynthError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A planar patch: disparity plane over the left-image rectangle [x0, x1] x [y0, y1] (pixel centres included).
struct Patch {
  double a, b, c;
  double x0, x1, y0, y1;
  uint32_t textureSeed;
  double disparity(double x, double y) const { return a * x + b * y + c; }
  // Pixel squares, not centres, bound the patch, so its edge in the right view is continuous.
  bool covers(double x, double y) const { return x >= x0 - 0.5 && x < x1 + 0.5 && y >= y0 && y <= y1; }
};

// Coordinates scale with the frame so the layout keeps its shape at any size; disparities do not.
std::vector<Patch> makeScene(int width, int height) {
  const double sx = width / 640.0, sy = height / 360.0;
  const double inf = 1e9;
  return {
      {1.0 / 64 / sx, 0, 8, -inf, inf, -inf, inf, 11},                                          // back wall, 8..18
      {0, 7.0 / 16 / sy, -61.25, -inf, inf, 140 * sy, inf, 23},                                 // ground, to ~96
      {-3.0 / 16 / sx, 0, 60, 20 * sx, 200 * sx, 40 * sy, 250 * sy, 37},                       // facade 56..22
      {1.0 / 16 / sx, 3.0 / 64 / sy, 30, 230 * sx, 360 * sx, 60 * sy, 200 * sy, 41},            // tilted panel
      {0, 0, 88, 400 * sx, 540 * sx, 150 * sy, 300 * sy, 53},                                   // box, d = 88
  };
}

uint32_t hash3(int32_t i, int32_t j, uint32_t seed) {
  uint32_t h = static_cast<uint32_t>(i) * 0x8da6b343u ^ static_cast<uint32_t>(j) * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  h *= 0x297a2d39u;
  h ^= h >> 15;
  return h;
}

// Value noise in [-1, 1]: random values on a lattice of `cell` pixels, blended with a smooth step.
double valueNoise(double x, double y, double cell, uint32_t seed) {
  const double u = x / cell, v = y / cell;
  const double fu = std::floor(u), fv = std::floor(v);
  const int32_t i = static_cast<int32_t>(fu), j = static_cast<int32_t>(fv);
  double tu = u - fu, tv = v - fv;
  tu = tu * tu * (3 - 2 * tu);
  tv = tv * tv * (3 - 2 * tv);
  auto value = [&](int32_t di, int32_t dj) { return hash3(i + di, j + dj, seed) / 2147483647.5 - 1.0; };
  const double top = value(0, 0) * (1 - tu) + value(1, 0) * tu;
  const double bottom = value(0, 1) * (1 - tu) + value(1, 1) * tu;
  return top * (1 - tv) + bottom * tv;
}

double texture(const Patch& patch, double x, double y) {
  const uint32_t s = patch.textureSeed;
  return 128 + 45 * valueNoise(x, y, 3, s) + 30 * valueNoise(x, y, 7, s + 1) + 25 * valueNoise(x, y, 19, s + 2);
}

// The visible patch at a left pixel, or -1 when nothing covers it.
int visibleLeft(const std::vector<Patch>& scene, double x, double y) {
  int best = -1;
  for (size_t k = 0; k < scene.size(); ++k)
    if (scene[k].covers(x, y) && (best < 0 || scene[k].disparity(x, y) > scene[best].disparity(x, y)))
      best = static_cast<int>(k);
  return best;
}

// The visible patch at right-image column xr: the patch point with x - d(x, y) = xr and the largest d.
int visibleRight(const std::vector<Patch>& scene, double xr, double y, double* leftX) {
  int best = -1;
  double bestD = 0, bestX = 0;
  for (size_t k = 0; k < scene.size(); ++k) {
    const Patch& p = scene[k];
    const double x = (xr + p.b * y + p.c) / (1 - p.a);
    if (!p.covers(x, y)) continue;
    const double d = p.disparity(x, y);
    if (best < 0 || d > bestD) {
      best = static_cast<int>(k);
      bestD = d;
      bestX = x;
    }
  }
  *leftX = bestX;
  return best;
}

// Deterministic zero-mean noise (sum of 4 uniforms, variance scaled to sigma^2).
double pixelNoise(int x, int y, uint32_t seed, double sigma) {
  if (sigma <= 0) return 0;
  double sum = 0;
  for (uint32_t k = 0; k < 4; ++k) sum += hash3(x, y, seed * 4 + k) / 4294967295.0 - 0.5;
  return sum * sigma * std::sqrt(3.0);
}

void writePfm(const std::string& path, const cv::Mat& map) {
  std::ofstream out(path, std::ios::binary);
  out << "Pf\n" << map.cols << " " << map.rows << "\n-1.0\n";
  for (int y = map.rows - 1; y >= 0; --y)
    out.write(reinterpret_cast<const char*>(map.ptr<float>(y)), static_cast<std::streamsize>(map.cols * sizeof(float)));
  if (!out) throw SynthError("cannot write " + path);
}

void writeImage(const std::string& path, const cv::Mat& image) {
  if (!cv::imwrite(path, image)) throw SynthError("cannot write " + path);
}

int parseInt(const std::string& key, const std::string& text) {
  size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty()) throw SynthError("not an integer for " + key + ": " + text);
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  try {
    std::string outDir;
    int width = 640, height = 360, seed = 1;
    double noise = 0;
    for (int i = 1; i < argc; ++i) {
      const std::string key = argv[i];
      if (key == "-h" || key == "--help") {
        std::cout << "usage: ielas-synth --out DIR [--width 640] [--height 360] [--noise SIGMA] [--seed N]\n";
        return 0;
      }
      if (i + 1 >= argc) throw SynthError("missing value after " + key);
      const std::string value = argv[++i];
      if (key == "--out") outDir = value;
      else if (key == "--width") width = parseInt(key, value);
      else if (key == "--height") height = parseInt(key, value);
      else if (key == "--seed") seed = parseInt(key, value);
      else if (key == "--noise") {
        char* end = nullptr;
        noise = std::strtod(value.c_str(), &end);
        if (value.empty() || *end != '\0' || noise < 0) throw SynthError("--noise wants a sigma >= 0, not " + value);
      }
      else throw SynthError("unknown option " + key);
    }
    if (outDir.empty()) throw SynthError("missing --out DIR");
    if (width < 32 || height < 16 || width > 4096 || height > 4096)
      throw SynthError("size must be 32x16 to 4096x4096");
    mkdir(outDir.c_str(), 0755);
    struct stat info;
    if (stat(outDir.c_str(), &info) != 0 || !S_ISDIR(info.st_mode)) throw SynthError("cannot create " + outDir);

    const std::vector<Patch> scene = makeScene(width, height);
    cv::Mat left(height, width, CV_8U), right(height, width, CV_8U);
    cv::Mat disp(height, width, CV_32F), nonocc(height, width, CV_8U);
    const uint32_t noiseSeed = static_cast<uint32_t>(seed);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const int k = visibleLeft(scene, x, y);  // the back wall covers everything, so k >= 0
        const double d = scene[k].disparity(x, y);
        left.at<uint8_t>(y, x) =
            cv::saturate_cast<uint8_t>(std::lround(texture(scene[k], x, y) + pixelNoise(x, y, 2 * noiseSeed, noise)));
        disp.at<float>(y, x) = static_cast<float>(d);
        double seenX = 0;
        const double xr = x - d;
        const int seen = xr < -0.5 ? -1 : visibleRight(scene, xr, y, &seenX);
        nonocc.at<uint8_t>(y, x) = seen == k ? 255 : 0;

        double sourceX = 0;
        const int r = visibleRight(scene, x, y, &sourceX);
        right.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(
            std::lround((r >= 0 ? texture(scene[r], sourceX, y) : 128) + pixelNoise(x, y, 2 * noiseSeed + 1, noise)));
      }
    cv::Mat kitti(height, width, CV_16U), kittiNoc;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        kitti.at<uint16_t>(y, x) = cv::saturate_cast<uint16_t>(std::lround(disp.at<float>(y, x) * 256.0));
    kitti.copyTo(kittiNoc);
    kittiNoc.setTo(0, nonocc == 0);

    writeImage(outDir + "/left.png", left);
    writeImage(outDir + "/right.png", right);
    writeImage(outDir + "/left.pgm", left);
    writeImage(outDir + "/right.pgm", right);
    writePfm(outDir + "/disp.pfm", disp);
    writeImage(outDir + "/disp.png", kitti);
    writeImage(outDir + "/disp_noc.png", kittiNoc);
    writeImage(outDir + "/nonocc.png", nonocc);
    std::cout << "ielas-synth: " << width << "x" << height << " scene in " << outDir << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "ielas-synth: " << e.what() << std::endl;
    return 1;
  }
}
