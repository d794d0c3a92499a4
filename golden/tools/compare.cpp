// ielas-compare A_DIR B_DIR: bit-exact comparison of every .npy present in both directories (make compare).
#include <dirent.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "ielas/npy.hpp"

using namespace ielas;

namespace {

std::vector<std::string> npyFiles(const std::string& dir) {
  std::vector<std::string> names;
  DIR* d = opendir(dir.c_str());
  if (!d) throw std::runtime_error("cannot open directory " + dir);
  while (dirent* e = readdir(d)) {
    std::string n = e->d_name;
    if (n.size() > 4 && n.compare(n.size() - 4, 4, ".npy") == 0) names.push_back(n);
  }
  closedir(d);
  std::sort(names.begin(), names.end());
  return names;
}

std::string shapeText(const std::vector<int>& s) {
  std::string t = "(";
  for (size_t i = 0; i < s.size(); ++i) t += (i ? ", " : "") + std::to_string(s[i]);
  return t + ")";
}

std::string indexText(size_t flat, const std::vector<int>& shape) {
  std::vector<int> idx(shape.size());
  for (size_t k = shape.size(); k-- > 0;) {
    idx[k] = static_cast<int>(flat % shape[k]);
    flat /= shape[k];
  }
  return shapeText(idx);
}

// Mismatch mask over the first two dimensions (rows, cols); trailing dimensions are OR-ed.
void writeDiffImage(const std::string& path, const NpyArray& a, const NpyArray& b) {
  const int rows = a.shape[0], cols = a.shape.size() > 1 ? a.shape[1] : 1;
  const size_t inner = a.count() / (static_cast<size_t>(rows) * cols);
  cv::Mat img(rows, cols, CV_8U, cv::Scalar(0));
  for (size_t i = 0; i < a.count(); ++i)
    if (a.value(i) != b.value(i)) {
      size_t pixel = i / inner;
      img.at<uint8_t>(static_cast<int>(pixel / cols), static_cast<int>(pixel % cols)) = 255;
    }
  cv::imwrite(path, img);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: ielas-compare A_DIR B_DIR\n");
    return 2;
  }
  const std::string dirA = argv[1], dirB = argv[2];
  try {
    std::vector<std::string> a = npyFiles(dirA), b = npyFiles(dirB);
    size_t files = 0, values = 0, mismatches = 0, badFiles = 0;
    bool firstReported = false;
    for (const std::string& name : a) {
      if (!std::binary_search(b.begin(), b.end(), name)) continue;
      NpyArray x = readNpy(dirA + "/" + name), y = readNpy(dirB + "/" + name);
      ++files;
      std::string base = name.substr(0, name.size() - 4);
      if (x.descr != y.descr || x.shape != y.shape) {
        ++badFiles;
        std::printf("%s: dtype/shape differ: %s %s vs %s %s\n", name.c_str(), x.descr.c_str(), shapeText(x.shape).c_str(),
                    y.descr.c_str(), shapeText(y.shape).c_str());
        firstReported = true;
        continue;
      }
      size_t fileMismatches = 0;
      for (size_t i = 0; i < x.count(); ++i) {
        if (x.value(i) == y.value(i)) continue;
        if (!firstReported) {
          std::printf("first mismatch: %s at %s: %lld (A) vs %lld (B)\n", name.c_str(), indexText(i, x.shape).c_str(),
                      static_cast<long long>(x.value(i)), static_cast<long long>(y.value(i)));
          firstReported = true;
        }
        ++fileMismatches;
      }
      values += x.count();
      if (fileMismatches) {
        ++badFiles;
        mismatches += fileMismatches;
        std::string diff = dirA + "/diff_" + base + ".png";
        writeDiffImage(diff, x, y);
        std::printf("%s: %zu of %zu values differ (diff image %s)\n", name.c_str(), fileMismatches, x.count(), diff.c_str());
      }
    }
    std::printf("compared %zu files, %zu values\n", files, values);
    if (files == 0) {
      std::printf("FAIL: no .npy file present in both directories\n");
      return 1;
    }
    if (badFiles) {
      std::printf("FAIL: %zu mismatching values, %zu files differ\n", mismatches, badFiles);
      return 1;
    }
    std::printf("OK: all equal\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ielas-compare: error: %s\n", e.what());
    return 2;
  }
}
