// Input images and disparity outputs.
#include "ielas/image_io.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include <sys/stat.h>
#include <unistd.h>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace ielas {

namespace {

// The largest frame any configuration accepts (maxWidth, maxHeight <= 8192): larger headers fail before decoding.
constexpr uint64_t kMaxSide = 8192;

[[noreturn]] void imageError(const std::string& path, const std::string& reason) {
  throw std::runtime_error("image " + path + ": " + reason);
}

std::string readFileBytes(const std::string& path) {
  struct stat st;
  if (stat(path.c_str(), &st) != 0) throw std::runtime_error("cannot read image " + path + ": " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw std::runtime_error("cannot read image " + path + ": is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read image " + path + ": " + std::strerror(errno));
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw std::runtime_error("cannot read image " + path + ": read error");
  return ss.str();
}

uint32_t bigEndian32(const std::string& b, size_t at) {
  return static_cast<uint32_t>(static_cast<unsigned char>(b[at])) << 24 |
         static_cast<uint32_t>(static_cast<unsigned char>(b[at + 1])) << 16 |
         static_cast<uint32_t>(static_cast<unsigned char>(b[at + 2])) << 8 |
         static_cast<uint32_t>(static_cast<unsigned char>(b[at + 3]));
}

void checkSide(const std::string& path, uint64_t w, uint64_t h) {
  if (w > kMaxSide || h > kMaxSide)
    imageError(path, "size " + std::to_string(w) + "x" + std::to_string(h) + " is outside 32x16..8192x8192");
}

// PNG: the IHDR fields (8 bits per sample: grey, grey+alpha, RGB, RGBA or an 8-bit palette) and a chunk walk that
// must reach IEND, so a truncated file fails here and never reaches libpng.
void checkPngHeader(const std::string& path, const std::string& b) {
  const std::string corrupt = "truncated or corrupt PNG";
  if (b.size() < 8 + 8 + 13 + 4 || b.compare(12, 4, "IHDR") != 0 || bigEndian32(b, 8) != 13)
    imageError(path, corrupt + " (no IHDR chunk)");
  const uint32_t w = bigEndian32(b, 16), h = bigEndian32(b, 20);
  const int depth = static_cast<unsigned char>(b[24]), colour = static_cast<unsigned char>(b[25]);
  const bool legal = (colour == 0 && (depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16)) ||
                     (colour == 3 && (depth == 1 || depth == 2 || depth == 4 || depth == 8)) ||
                     ((colour == 2 || colour == 4 || colour == 6) && (depth == 8 || depth == 16));
  if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu || !legal)
    imageError(path, corrupt + " (IHDR: " + std::to_string(w) + "x" + std::to_string(h) + ", bit depth " +
                         std::to_string(depth) + ", colour type " + std::to_string(colour) + ")");
  if (depth != 8)
    imageError(path, std::to_string(depth) + "-bit " + (colour == 3 ? "palette " : "") +
                         "PNG (8-bit grey or colour expected)");
  bool idat = false;
  for (size_t at = 8;;) {
    if (b.size() - at < 12) imageError(path, corrupt + " (no IEND chunk)");
    const uint64_t len = bigEndian32(b, at);
    if (len > 0x7fffffffu || b.size() - at - 12 < len)
      imageError(path, corrupt + " (a chunk runs past the end of the file)");
    const std::string type = b.substr(at + 4, 4);
    if (type == "IEND") break;
    idat = idat || type == "IDAT";
    at += 12 + len;
  }
  if (!idat) imageError(path, corrupt + " (no IDAT chunk)");
  checkSide(path, w, h);
}

// PGM (P5 binary, P2 plain): maxval 1..255, and a P5 file holds all its pixels.
void checkPgmHeader(const std::string& path, const std::string& b) {
  const std::string corrupt = "truncated or corrupt PGM";
  size_t at = 2;
  auto number = [&](const char* what) -> uint64_t {
    while (at < b.size()) {  // whitespace and # comments
      if (b[at] == '#') {
        while (at < b.size() && b[at] != '\n' && b[at] != '\r') ++at;
      } else if (std::isspace(static_cast<unsigned char>(b[at]))) {
        ++at;
      } else {
        break;
      }
    }
    uint64_t v = 0;
    size_t digits = 0;
    while (at < b.size() && std::isdigit(static_cast<unsigned char>(b[at])) && digits < 10) {
      v = v * 10 + static_cast<uint64_t>(b[at] - '0');
      ++at;
      ++digits;
    }
    if (digits == 0 || (at < b.size() && !std::isspace(static_cast<unsigned char>(b[at]))))
      imageError(path, corrupt + " (header: no valid " + what + ")");
    return v;
  };
  const uint64_t w = number("width"), h = number("height"), maxval = number("maxval");
  if (at >= b.size()) imageError(path, corrupt + " (no pixels)");
  ++at;  // the single whitespace character after maxval
  if (w == 0 || h == 0 || maxval == 0 || maxval > 65535)
    imageError(path, corrupt + " (header: " + std::to_string(w) + "x" + std::to_string(h) + ", maxval " +
                         std::to_string(maxval) + ")");
  if (maxval > 255) imageError(path, "16-bit PGM (maxval " + std::to_string(maxval) + "; 8-bit expected)");
  checkSide(path, w, h);
  if (b[1] == '5' && b.size() - at < w * h)
    imageError(path, "truncated PGM (" + std::to_string(w) + "x" + std::to_string(h) + " needs " +
                         std::to_string(w * h) + " bytes of pixels, the file has " +
                         std::to_string(b.size() - at) + ")");
}

// Decodes with OpenCV while fd 2 goes to a temporary file and OpenCV's own logging is off, so neither libpng
// ("libpng error: ...") nor OpenCV prints anything; returns the image and what they tried to print.
cv::Mat quietImread(const std::string& path, std::string& libraryText) {
  std::fflush(stderr);
  std::cerr.flush();
  FILE* capture = std::tmpfile();
  const int saved = capture ? dup(2) : -1;
  if (saved >= 0) dup2(fileno(capture), 2);
  const auto level = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  cv::Mat raw;
  try {
    raw = cv::imread(path, cv::IMREAD_UNCHANGED);  // unchanged: colour is converted below, with our own rule
  } catch (const cv::Exception&) {
    raw.release();
  }
  cv::utils::logging::setLogLevel(level);
  std::fflush(stderr);
  std::cerr.flush();
  if (saved >= 0) {
    dup2(saved, 2);
    close(saved);
  }
  if (capture) {
    std::rewind(capture);
    char buf[512];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, capture)) > 0) libraryText.append(buf, n);
    std::fclose(capture);
  }
  return raw;
}

// libpng's first message ("libpng error: Read Error" -> "libpng: Read Error"), for the one error line.
std::string libpngReason(const std::string& text) {
  const std::string tag = "libpng error: ";
  const size_t at = text.find(tag);
  if (at == std::string::npos) return "";
  const size_t end = text.find_first_of("\r\n", at);
  const size_t from = at + tag.size();
  return " (libpng: " + text.substr(from, end == std::string::npos ? std::string::npos : end - from) + ")";
}

}  // namespace

cv::Mat loadGray8(const std::string& path) {
  const std::string bytes = readFileBytes(path);
  const bool png = bytes.size() >= 8 && bytes.compare(0, 8, "\x89PNG\r\n\x1a\n", 8) == 0;
  const bool pnm = bytes.size() >= 2 && bytes[0] == 'P';
  if (png) {
    checkPngHeader(path, bytes);
  } else if (pnm && (bytes[1] == '2' || bytes[1] == '5')) {
    checkPgmHeader(path, bytes);
  } else if (pnm && (bytes[1] == '1' || bytes[1] == '4')) {
    imageError(path, "not a PNG or PGM image (a 1-bit PBM)");
  } else if (pnm && (bytes[1] == '3' || bytes[1] == '6')) {
    imageError(path, "not a PNG or PGM image (a PPM)");
  } else if (pnm && (bytes[1] == 'f' || bytes[1] == 'F')) {
    imageError(path, "not a PNG or PGM image (a PFM)");
  } else {
    imageError(path, "not a PNG or PGM image");
  }
  std::string libraryText;
  cv::Mat raw = quietImread(path, libraryText);
  if (raw.empty())
    imageError(path, std::string(png ? "truncated or corrupt PNG" : "truncated or corrupt PGM") + libpngReason(libraryText));
  if (raw.depth() != CV_8U) imageError(path, "deeper than 8 bits (8-bit grey or colour expected)");
  cv::Mat grey;
  switch (raw.channels()) {
    case 1: grey = raw; break;
    case 3: cv::cvtColor(raw, grey, cv::COLOR_BGR2GRAY); break;
    case 4: cv::cvtColor(raw, grey, cv::COLOR_BGRA2GRAY); break;
    default: imageError(path, std::to_string(raw.channels()) + " channels (1, 3 or 4 expected)");
  }
  return grey.isContinuous() ? grey : grey.clone();
}

void checkPairSize(const cv::Mat& left, const cv::Mat& right, int maxWidth, int maxHeight, const std::string& what) {
  if (left.size() != right.size())
    throw std::runtime_error("left/right size mismatch: " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                             " vs " + std::to_string(right.cols) + "x" + std::to_string(right.rows));
  if (left.cols < 32 || left.rows < 16 || left.cols > maxWidth || left.rows > maxHeight)
    throw std::runtime_error("image size " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                             " is outside 32x16.." + std::to_string(maxWidth) + "x" + std::to_string(maxHeight) + " (" + what + ")");
}

void writePfm(const std::string& path, const cv::Mat& disparity) {
  CV_Assert(disparity.type() == CV_32F);
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << "Pf\n" << disparity.cols << " " << disparity.rows << "\n-1.0\n";  // negative scale = little-endian
  for (int y = disparity.rows - 1; y >= 0; --y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      float v = row[x] < 0.0f ? -1.0f : row[x];
      uint32_t bits;
      std::memcpy(&bits, &v, 4);
      unsigned char le[4] = {static_cast<unsigned char>(bits), static_cast<unsigned char>(bits >> 8),
                             static_cast<unsigned char>(bits >> 16), static_cast<unsigned char>(bits >> 24)};
      out.write(reinterpret_cast<const char*>(le), 4);
    }
  }
  if (!out) throw std::runtime_error("cannot write " + path);
}

void writeKittiPng(const std::string& path, const cv::Mat& disparity) {
  CV_Assert(disparity.type() == CV_32F);
  cv::Mat out(disparity.size(), CV_16U);
  for (int y = 0; y < disparity.rows; ++y)
    for (int x = 0; x < disparity.cols; ++x) {
      float d = disparity.at<float>(y, x);
      // 0 means invalid in KITTI, so a valid 0 disparity becomes the smallest valid code 1.
      double v = d < 0.0f ? 0.0 : std::max(1.0, std::min(65535.0, std::round(d * 256.0)));
      out.at<uint16_t>(y, x) = static_cast<uint16_t>(v);
    }
  if (!cv::imwrite(path, out)) throw std::runtime_error("cannot write " + path);
}

cv::Mat readPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (magic != "Pf" || w <= 0 || h <= 0 || scale == 0) throw std::runtime_error("not a grey PFM file: " + path);
  cv::Mat d(h, w, CV_32F);
  for (int y = h - 1; y >= 0; --y)
    for (int x = 0; x < w; ++x) {
      unsigned char b[4];
      if (!in.read(reinterpret_cast<char*>(b), 4)) throw std::runtime_error("truncated PFM file: " + path);
      uint32_t bits = scale < 0 ? (b[0] | b[1] << 8 | b[2] << 16 | static_cast<uint32_t>(b[3]) << 24)
                                : (b[3] | b[2] << 8 | b[1] << 16 | static_cast<uint32_t>(b[0]) << 24);
      float v;
      std::memcpy(&v, &bits, 4);
      d.at<float>(y, x) = v;
    }
  return d;
}

}  // namespace ielas
