// NumPy .npy reader/writer (format version 1.0).
#include "ielas/npy.hpp"

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace ielas {

int npyItemSize(const std::string& descr) {
  if (descr == "|u1") return 1;
  if (descr == "<i2" || descr == "<u2") return 2;
  if (descr == "<i4") return 4;
  throw std::runtime_error("unsupported npy dtype '" + descr + "' (|u1, <i2, <u2, <i4)");
}

size_t NpyArray::count() const {
  size_t n = 1;
  for (int s : shape) n *= static_cast<size_t>(s);
  return n;
}

int NpyArray::itemSize() const { return npyItemSize(descr); }

int64_t NpyArray::value(size_t i) const {
  const unsigned char* p = data.data() + i * itemSize();
  if (descr == "|u1") return p[0];
  if (descr == "<u2") return static_cast<uint16_t>(p[0] | p[1] << 8);
  if (descr == "<i2") return static_cast<int16_t>(static_cast<uint16_t>(p[0] | p[1] << 8));
  return static_cast<int32_t>(static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 |
                              static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24);
}

std::string npyHeader(const std::string& descr, const std::vector<int>& shape) {
  npyItemSize(descr);
  if (shape.size() < 1 || shape.size() > 4) throw std::runtime_error("npy: 1 to 4 dimensions supported");
  std::ostringstream dict;
  dict << "{'descr': '" << descr << "', 'fortran_order': False, 'shape': (";
  for (size_t i = 0; i < shape.size(); ++i) dict << (i ? ", " : "") << shape[i];
  if (shape.size() == 1) dict << ",";  // numpy's one-element tuple
  dict << "), }";
  std::string header = dict.str();
  size_t total = 10 + header.size() + 1;  // preamble + dict + '\n'
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  std::string out("\x93NUMPY\x01\x00", 8);
  out.push_back(static_cast<char>(header.size() & 0xff));
  out.push_back(static_cast<char>(header.size() >> 8));
  return out + header;
}

void writeNpy(const std::string& path, const std::string& descr, const std::vector<int>& shape, const void* data) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  std::string header = npyHeader(descr, shape);
  size_t bytes = static_cast<size_t>(npyItemSize(descr));
  for (int s : shape) bytes *= static_cast<size_t>(s);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  // The host is little-endian (x86/ARM), so element bytes go out as they are.
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  if (!out) throw std::runtime_error("cannot write " + path);
}

namespace {

std::string dictValue(const std::string& dict, const std::string& key, const std::string& path) {
  size_t k = dict.find("'" + key + "'");
  if (k == std::string::npos) throw std::runtime_error("npy " + path + ": header has no '" + key + "'");
  size_t colon = dict.find(':', k);
  if (colon == std::string::npos) throw std::runtime_error("npy " + path + ": malformed header");
  size_t start = dict.find_first_not_of(' ', colon + 1);
  if (start == std::string::npos) throw std::runtime_error("npy " + path + ": malformed header");
  size_t end;
  if (dict[start] == '\'') {
    end = dict.find('\'', start + 1);
    if (end == std::string::npos) throw std::runtime_error("npy " + path + ": malformed header");
    return dict.substr(start + 1, end - start - 1);
  }
  if (dict[start] == '(') {
    end = dict.find(')', start);
    if (end == std::string::npos) throw std::runtime_error("npy " + path + ": malformed header");
    return dict.substr(start, end - start + 1);
  }
  end = dict.find_first_of(",}", start);
  return dict.substr(start, end - start);
}

}  // namespace

NpyArray readNpy(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  char pre[10];
  if (!in.read(pre, 10) || std::memcmp(pre, "\x93NUMPY", 6) != 0) throw std::runtime_error("not an npy file: " + path);
  if (pre[6] != 1 || pre[7] != 0) throw std::runtime_error("npy " + path + ": only format version 1.0 is supported");
  size_t headerLen = static_cast<unsigned char>(pre[8]) | static_cast<unsigned char>(pre[9]) << 8;
  std::string dict(headerLen, '\0');
  if (!in.read(&dict[0], static_cast<std::streamsize>(headerLen))) throw std::runtime_error("npy " + path + ": truncated header");
  NpyArray a;
  a.descr = dictValue(dict, "descr", path);
  npyItemSize(a.descr);
  if (dictValue(dict, "fortran_order", path) != "False") throw std::runtime_error("npy " + path + ": Fortran order is not supported");
  std::string shape = dictValue(dict, "shape", path);
  std::string digits;
  for (size_t i = 1; i < shape.size(); ++i) {
    char c = shape[i];
    if (c >= '0' && c <= '9') {
      digits.push_back(c);
    } else if (!digits.empty()) {
      a.shape.push_back(std::stoi(digits));
      digits.clear();
    }
  }
  if (a.shape.empty()) throw std::runtime_error("npy " + path + ": scalar arrays are not supported");
  a.data.resize(a.count() * a.itemSize());
  if (!in.read(reinterpret_cast<char*>(a.data.data()), static_cast<std::streamsize>(a.data.size())))
    throw std::runtime_error("npy " + path + ": truncated data");
  return a;
}

void writeNpyMat(const std::string& path, const cv::Mat& m) {
  CV_Assert(m.dims == 2);
  cv::Mat c = m.isContinuous() ? m : m.clone();
  std::string descr;
  switch (c.depth()) {
    case CV_8U: descr = "|u1"; break;
    case CV_16S: descr = "<i2"; break;
    case CV_16U: descr = "<u2"; break;
    case CV_32S: descr = "<i4"; break;
    default: throw std::runtime_error("writeNpyMat: unsupported Mat depth");
  }
  std::vector<int> shape = {c.rows, c.cols};
  if (c.channels() > 1) shape.push_back(c.channels());
  writeNpy(path, descr, shape, c.data);
}

}  // namespace ielas
