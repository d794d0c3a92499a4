// The command-line contract of docs/interfaces.md §2-3: one-line errors with a non-zero exit, dump files, compare.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include <sys/stat.h>
#include <sys/wait.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "check.hpp"
#include "ielas/image_io.hpp"
#include "ielas/npy.hpp"

using namespace ielas;

namespace {

const std::string kTmp = std::string(IELAS_TEST_TMP_DIR) + "/cli";
const std::string kBin = IELAS_GOLDEN_BIN;
const std::string kCompare = std::string(IELAS_BIN_DIR) + "/ielas-compare";

struct Result {
  int exitCode;
  std::string out, err;
};

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Result run(const std::string& cmd) {
  const std::string o = kTmp + "/stdout.txt", e = kTmp + "/stderr.txt";
  int status = std::system((cmd + " >" + o + " 2>" + e).c_str());
  Result r{WIFEXITED(status) ? WEXITSTATUS(status) : 128, readAll(o), readAll(e)};
  return r;
}

int lineCount(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// An error: non-zero exit, exactly one line on stderr, holding `fragment`.
void expectError(const std::string& args, const std::string& fragment) {
  Result r = run(kBin + " " + args);
  const bool ok = r.exitCode != 0 && lineCount(r.err) == 1 && r.err.find(fragment) != std::string::npos;
  CHECK(ok);
  if (!ok) std::cerr << "  args: " << args << "\n  exit " << r.exitCode << ", stderr: " << r.err << std::endl;
}

cv::Mat randomImage(int w, int h, int seed) {
  cv::Mat m(h, w, CV_8U);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

}  // namespace

int main() {
  mkdir(IELAS_TEST_TMP_DIR, 0777);
  mkdir(kTmp.c_str(), 0777);
  const std::string L = kTmp + "/left.png", R = kTmp + "/right.png";
  cv::Mat left = randomImage(64, 32, 1);
  cv::Mat right;
  // Right view = left shifted by 4 px, so the pair has a real match.
  cv::hconcat(left.colRange(4, 64), randomImage(4, 32, 2), right);
  cv::imwrite(L, left);
  cv::imwrite(R, right);
  cv::imwrite(kTmp + "/wide.png", randomImage(65, 32, 3));
  cv::imwrite(kTmp + "/small.png", randomImage(31, 16, 4));
  cv::imwrite(kTmp + "/small_r.png", randomImage(31, 16, 5));
  cv::imwrite(kTmp + "/big.png", randomImage(129, 64, 6));
  cv::imwrite(kTmp + "/big_r.png", randomImage(129, 64, 7));
  cv::Mat deep(32, 64, CV_16U, cv::Scalar(1000));
  cv::imwrite(kTmp + "/deep.png", deep);
  cv::Mat colour(32, 64, CV_8UC3, cv::Scalar(10, 20, 30));
  cv::imwrite(kTmp + "/colour.png", colour);
  { std::ofstream(kTmp + "/broken.json") << "{ \"name\": \"x\", "; }
  { std::ofstream(kTmp + "/notimage.png") << "hello"; }
  // Damaged and unsupported images, each written here from a good one.
  {
    std::vector<unsigned char> png;
    cv::imencode(".png", left, png);
    std::ofstream(kTmp + "/truncated.png", std::ios::binary).write(reinterpret_cast<const char*>(png.data()),
                                                                   static_cast<std::streamsize>(png.size() / 2));
    // A flipped byte inside the compressed pixels: the chunks are intact, so libpng itself finds the damage.
    std::vector<unsigned char> corrupt = png;
    const std::string bytes(corrupt.begin(), corrupt.end());
    corrupt[bytes.find("IDAT") + 20] ^= 0x5a;
    std::ofstream(kTmp + "/corrupt.png", std::ios::binary).write(reinterpret_cast<const char*>(corrupt.data()),
                                                                 static_cast<std::streamsize>(corrupt.size()));
    cv::Mat bilevel = left > 127;
    cv::imwrite(kTmp + "/bilevel.png", bilevel, {cv::IMWRITE_PNG_BILEVEL, 1});
    std::ofstream pgm(kTmp + "/truncated.pgm", std::ios::binary);
    pgm << "P5\n64 32\n255\n" << std::string(64 * 10, '\x40');
    std::ofstream deepPgm(kTmp + "/deep.pgm", std::ios::binary);
    deepPgm << "P5\n64 32\n65535\n" << std::string(64 * 32 * 2, '\x01');
    std::ofstream ppm(kTmp + "/colour.ppm", std::ios::binary);
    ppm << "P6\n64 32\n255\n" << std::string(64 * 32 * 3, '\x40');
    std::ofstream plain(kTmp + "/plain.pgm");
    plain << "P2\n# plain PGM\n64 32\n255\n";
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 64; ++x) plain << static_cast<int>(left.at<uint8_t>(y, x)) << (x == 63 ? "\n" : " ");
  }

  const std::string pair = " --left " + L + " --right " + R;
  expectError("dump --mode ielas --config small --left " + kTmp + "/missing.png --right " + R + " --out " + kTmp + "/d",
              "cannot read image");
  expectError("dump --mode ielas --config small --left " + kTmp + "/notimage.png --right " + R + " --out " + kTmp + "/d",
              "notimage.png: not a PNG or PGM image");
  expectError("dump --mode ielas --config small --left " + kTmp + "/colour.ppm --right " + R + " --out " + kTmp + "/d",
              "colour.ppm: not a PNG or PGM image");
  expectError("dump --mode ielas --config small --left " + L + " --right " + kTmp + "/truncated.png --out " + kTmp + "/d",
              "truncated.png: truncated or corrupt PNG");
  expectError("dump --mode ielas --config small --left " + kTmp + "/corrupt.png --right " + R + " --out " + kTmp + "/d",
              "corrupt.png: truncated or corrupt PNG (libpng: ");
  expectError("dump --mode ielas --config small --left " + kTmp + "/truncated.pgm --right " + R + " --out " + kTmp + "/d",
              "truncated.pgm: truncated PGM (64x32 needs 2048 bytes of pixels, the file has 640)");
  expectError("dump --mode ielas --config small --left " + kTmp + "/bilevel.png --right " + R + " --out " + kTmp + "/d",
              "bilevel.png: 1-bit PNG (8-bit grey or colour expected)");
  expectError("dump --mode ielas --config small --left " + kTmp + "/deep.pgm --right " + R + " --out " + kTmp + "/d",
              "deep.pgm: 16-bit PGM (maxval 65535; 8-bit expected)");
  expectError("match --mode ielas --preset robotics --disp-max 1e10" + std::string(" --left ") + L + " --right " + R +
              " --out " + kTmp + "/x.pfm", "--disp-max 1e10 is not an integer in 1..1023");
  expectError("match --mode ielas --preset robotics --disp-max 10000000000 --left " + L + " --right " + R + " --out " +
              kTmp + "/x.pfm", "--disp-max 10000000000 is not an integer in 1..1023");
  expectError("dump --mode ielas --config small --left " + L + " --right " + kTmp + "/wide.png --out " + kTmp + "/d",
              "size mismatch");
  expectError("dump --mode ielas --config small --left " + kTmp + "/deep.png --right " + R + " --out " + kTmp + "/d",
              "deep.png: 16-bit PNG (8-bit grey or colour expected)");
  expectError("dump --mode ielas --config small --left " + kTmp + "/big.png --right " + kTmp + "/big_r.png --out " +
              kTmp + "/d", "outside 32x16..128x64");
  expectError("dump --mode ielas --preset robotics --left " + kTmp + "/small.png --right " + kTmp + "/small_r.png --out " +
              kTmp + "/d", "outside 32x16");
  expectError("dump --mode ielas --preset indoor" + pair + " --out " + kTmp + "/d", "unknown preset");
  expectError("dump --mode ielas --config nosuchconfig" + pair + " --out " + kTmp + "/d", "unknown configuration");
  expectError("dump --mode ielas --config " + kTmp + "/broken.json" + pair + " --out " + kTmp + "/d", "malformed JSON");
  expectError("dump --mode ielas --config small" + pair, "missing option --out");
  expectError("dump --mode ielas --config small --bogus 1" + pair + " --out " + kTmp + "/d", "unknown option");
  expectError("match --mode ielas --config small" + pair + " --out " + kTmp + "/x.txt", ".pfm or .png");
  expectError("frobnicate", "unknown command");

  // A good dump: the early-stage files with the documented shapes and dtypes.
  Result ok = run(kBin + " dump --mode ielas --config small" + pair + " --out " + kTmp + "/dumpA");
  CHECK_EQ(ok.exitCode, 0);
  CHECK(ok.err.empty());
  NpyArray desc = readNpy(kTmp + "/dumpA/descriptor_L.npy");
  CHECK(desc.descr == "|u1");
  CHECK(desc.shape == std::vector<int>({32, 64, 16}));
  NpyArray sup = readNpy(kTmp + "/dumpA/support_L.npy");
  CHECK(sup.descr == "<i2");
  CHECK(sup.shape == std::vector<int>({8, 14}));  // 32 rows: 0..30 + 31; 64 cols: 0..60 + 63
  NpyArray grid = readNpy(kTmp + "/dumpA/grid_R.npy");
  CHECK(grid.shape == std::vector<int>({2, 4, 20}));
  NpyArray lattice = readNpy(kTmp + "/dumpA/lattice_L.npy");
  for (size_t i = 0; i < lattice.count(); ++i) CHECK(lattice.value(i) >= 0 && lattice.value(i) <= 31);
  // A colour input is accepted (converted to grey).
  CHECK_EQ(run(kBin + " dump --mode ielas --preset middlebury --disp-max 31 --left " + kTmp + "/colour.png --right " +
               kTmp + "/colour.png --out " + kTmp + "/dumpC").exitCode, 0);

  // A plain (P2) PGM of the left view is accepted, silently, and gives the same dump.
  {
    Result plain = run(kBin + " dump --mode ielas --config small --left " + kTmp + "/plain.pgm --right " + R + " --out " +
                       kTmp + "/dumpP");
    CHECK_EQ(plain.exitCode, 0);
    CHECK(plain.err.empty());
    CHECK(readAll(kTmp + "/dumpP/disparity.npy") == readAll(kTmp + "/dumpA/disparity.npy"));
  }

  // compare: identical dumps pass; a changed value fails, names the file and index, and writes a diff image.
  CHECK_EQ(run(kBin + " dump --mode ielas --config small" + pair + " --out " + kTmp + "/dumpB").exitCode, 0);
  Result same = run(kCompare + " " + kTmp + "/dumpA " + kTmp + "/dumpB");
  CHECK_EQ(same.exitCode, 0);
  CHECK(same.out.find("compared") != std::string::npos);
  std::vector<int16_t> sv(sup.count());
  for (size_t i = 0; i < sv.size(); ++i) sv[i] = static_cast<int16_t>(sup.value(i));
  sv[3 * 14 + 5] = static_cast<int16_t>(sv[3 * 14 + 5] + 7);
  writeNpy(kTmp + "/dumpB/support_L.npy", "<i2", sup.shape, sv.data());
  Result diff = run(kCompare + " " + kTmp + "/dumpA " + kTmp + "/dumpB");
  CHECK(diff.exitCode != 0);
  CHECK(diff.out.find("support_L.npy at (3, 5)") != std::string::npos);
  CHECK(diff.out.find("1 mismatching values") != std::string::npos);
  struct stat st;
  CHECK(stat((kTmp + "/dumpA/diff_support_L.png").c_str(), &st) == 0);
  // match writes the same map as the dump's disparity.npy (d * 16, -1 invalid): PFM = value / 16, invalid < 0.
  {
    CHECK_EQ(run(kBin + " match --mode ielas --config small" + pair + " --out " + kTmp + "/m.pfm").exitCode, 0);
    NpyArray disp = readNpy(kTmp + "/dumpA/disparity.npy");
    cv::Mat pfm = readPfm(kTmp + "/m.pfm");
    CHECK_EQ(pfm.rows, 32);
    CHECK_EQ(pfm.cols, 64);
    int mismatches = 0;
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 64; ++x) {
        const int64_t v = disp.value(static_cast<size_t>(y) * 64 + x);
        const float p = pfm.at<float>(y, x);
        if (v < 0 ? !(p < 0) : p != static_cast<float>(v) / 16.0f) ++mismatches;
      }
    CHECK_EQ(mismatches, 0);
  }
  mkdir((kTmp + "/empty").c_str(), 0777);
  CHECK(run(kCompare + " " + kTmp + "/dumpA " + kTmp + "/empty").exitCode != 0);
  return testExitCode("test_cli");
}
