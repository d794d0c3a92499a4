// Configuration loading (golden/configs/<name>.json from ElasParams) and the --preset configuration.
#include "ielas/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

#include <opencv2/core.hpp>

namespace ielas {
namespace {

bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

bool fileExists(const std::string& path) {
  std::ifstream f(path);
  return f.good();
}

std::string executableDir() {
  char buf[4096];
  ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return ".";
  std::string path(buf, static_cast<size_t>(n));
  size_t slash = path.rfind('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

std::vector<std::string> configDirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("IELAS_CONFIG_DIR")) dirs.emplace_back(env);
  dirs.push_back(executableDir() + "/../configs");
#ifdef IELAS_SOURCE_CONFIG_DIR
  dirs.emplace_back(IELAS_SOURCE_CONFIG_DIR);
#endif
  return dirs;
}

// Reads typed keys and turns any problem into a one-line message naming the file and the key.
class JsonReader {
 public:
  JsonReader(const cv::FileStorage& fs, const std::string& file) : fs_(fs), file_(file) {}

  cv::FileNode node(const char* key, bool required) const {
    cv::FileNode n = fs_[key];
    if (n.isNone() && required) throw std::runtime_error("configuration " + file_ + ": missing key '" + key + "'");
    return n;
  }
  void readInt(const char* key, int& out, bool required = true) const {
    cv::FileNode n = node(key, required);
    if (n.isNone()) return;
    if (!n.isInt() && !n.isReal()) throw std::runtime_error("configuration " + file_ + ": key '" + key + "' is not a number");
    out = static_cast<int>(n);
    if (n.isReal() && static_cast<double>(n) != out)
      throw std::runtime_error("configuration " + file_ + ": key '" + key + "' is not an integer");
  }
  void readBool(const char* key, bool& out) const {
    int v = 0;
    readInt(key, v);
    out = v != 0;
  }
  void readDouble(const char* key, double& out) const {
    cv::FileNode n = node(key, true);
    if (!n.isInt() && !n.isReal()) throw std::runtime_error("configuration " + file_ + ": key '" + key + "' is not a number");
    out = static_cast<double>(n);
  }
  void readString(const char* key, std::string& out, bool required = true) const {
    cv::FileNode n = node(key, required);
    if (n.isNone()) return;
    if (!n.isString()) throw std::runtime_error("configuration " + file_ + ": key '" + key + "' is not a string");
    out = static_cast<std::string>(n);
  }
  void readIntList(const char* key, std::vector<int>& out) const {
    cv::FileNode n = node(key, true);
    if (!n.isSeq()) throw std::runtime_error("configuration " + file_ + ": key '" + key + "' is not a list");
    out.clear();
    for (const cv::FileNode& e : n) {
      if (!e.isInt()) throw std::runtime_error("configuration " + file_ + ": key '" + key + "' holds a non-integer");
      out.push_back(static_cast<int>(e));
    }
  }

 private:
  const cv::FileStorage& fs_;
  std::string file_;
};

Config readConfigFile(const std::string& path) {
  if (!fileExists(path)) throw std::runtime_error("cannot read configuration file " + path);
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON))
      throw std::runtime_error("malformed JSON in configuration file " + path);
  } catch (const cv::Exception&) {
    throw std::runtime_error("malformed JSON in configuration file " + path);
  }
  if (!fs.root().isMap()) throw std::runtime_error("malformed JSON in configuration file " + path + " (not an object)");
  Config c;
  JsonReader r(fs, path);
  r.readString("name", c.name);
  r.readInt("maxWidth", c.maxWidth);
  r.readInt("maxHeight", c.maxHeight);
  r.readInt("dispMax", c.dispMax);
  r.readInt("windowSize", c.windowSize);
  r.readInt("storedDisparities", c.storedDisparities);
  r.readInt("candidateStep", c.candidateStep);
  r.readInt("gridSize", c.gridSize);
  r.readString("parameterSet", c.parameterSet);
  r.readInt("supportTexture", c.supportTexture);
  r.readInt("supportMinRange", c.supportMinRange);
  r.readInt("inconWindowSize", c.inconWindowSize);
  r.readInt("inconThreshold", c.inconThreshold);
  r.readInt("inconMinSupport", c.inconMinSupport);
  r.readInt("lrThreshold", c.lrThreshold);
  r.readDouble("beta", c.beta);
  r.readDouble("sigma", c.sigma);
  r.readInt("speckleSimThreshold", c.speckleSimThreshold);
  r.readInt("speckleSize", c.speckleSize);
  r.readInt("speckleWindowRows", c.speckleWindowRows);
  r.readInt("ipolColumnWindow", c.ipolColumnWindow);
  r.readString("fillRule", c.fillRule);
  r.readInt("fillEpsilon", c.fillEpsilon);
  r.readInt("sDelta", c.sDelta);
  r.readInt("epsilon", c.epsilon);
  r.readInt("fillC", c.fillC);
  r.readInt("supportLanes", c.supportLanes);
  r.readInt("denseLanes", c.denseLanes);
  r.readInt("supportThresholdPercent", c.supportThresholdPercent);
  r.readDouble("gamma", c.gamma);
  r.readDouble("sradius", c.sradius);
  r.readInt("planeRadius", c.planeRadius);
  r.readInt("matchTexture", c.matchTexture);
  r.readBool("addCorners", c.addCorners);
  r.readInt("ipolGapWidth", c.ipolGapWidth);
  r.readBool("filterMedian", c.filterMedian);
  r.readBool("filterAdaptiveMean", c.filterAdaptiveMean);
  r.readBool("postprocessOnlyLeft", c.postprocessOnlyLeft);
  r.readInt("descriptorBytes", c.descriptorBytes);
  r.readInt("descriptorMargin", c.descriptorMargin);
  r.readInt("supportMargin", c.supportMargin);
  r.readInt("latticeColsMax", c.latticeColsMax);
  r.readInt("latticeRowsMax", c.latticeRowsMax);
  r.readInt("gridColsMax", c.gridColsMax);
  r.readInt("gridRowsMax", c.gridRowsMax);
  r.readIntList("priorTable", c.priorTable);
  r.readString("gridKeep", c.gridKeep, false);
  r.readString("gridCorners", c.gridCorners, false);
  validateConfig(c);
  // Derived values must agree with the card parameters: a hand-edited JSON that breaks them is rejected.
  Config derived = c;
  deriveConfig(derived);
  if (derived.descriptorMargin != c.descriptorMargin || derived.supportMargin != c.supportMargin ||
      derived.latticeColsMax != c.latticeColsMax || derived.latticeRowsMax != c.latticeRowsMax ||
      derived.gridColsMax != c.gridColsMax || derived.gridRowsMax != c.gridRowsMax)
    throw std::runtime_error("configuration " + path + ": derived sizes do not match the card parameters");
  return c;
}

void rangeCheck(int value, int lo, int hi, const char* what) {
  if (value < lo || value > hi)
    throw std::runtime_error(std::string("configuration: ") + what + " = " + std::to_string(value) +
                             " is out of range (legal: " + std::to_string(lo) + ".." + std::to_string(hi) + ")");
}

}  // namespace

std::vector<int> computePriorTable(int dispMax, double gamma, double sigma, double beta) {
  std::vector<int> table;
  for (int delta = 0; delta <= dispMax; ++delta) {
    double n = std::exp(-(static_cast<double>(delta) * delta) / (2.0 * sigma * sigma));
    table.push_back(static_cast<int>((std::log(gamma) - std::log(gamma + n)) / beta));  // truncation, as libelas
  }
  return table;
}

void deriveConfig(Config& c) {
  c.descriptorBytes = 16;
  c.descriptorMargin = c.windowRadius() + 1;
  c.supportMargin = c.windowRadius() + c.descriptorMargin;
  c.latticeColsMax = c.latticeCount(c.maxWidth);
  c.latticeRowsMax = c.latticeCount(c.maxHeight);
  c.gridColsMax = c.gridCount(c.maxWidth);
  c.gridRowsMax = c.gridCount(c.maxHeight);
}

void validateConfig(const Config& c) {
  rangeCheck(c.maxWidth, 32, 8192, "maxWidth");
  rangeCheck(c.maxHeight, 16, 8192, "maxHeight");
  rangeCheck(c.dispMax, 1, 1023, "dispMax");
  if (c.windowSize != 3 && c.windowSize != 5 && c.windowSize != 7)
    throw std::runtime_error("configuration: windowSize = " + std::to_string(c.windowSize) + " is not supported (legal: 3, 5, 7)");
  rangeCheck(c.storedDisparities, 1, c.dispMax + 1, "storedDisparities");
  rangeCheck(c.candidateStep, 2, 16, "candidateStep");
  rangeCheck(c.gridSize, c.candidateStep, 256, "gridSize");
  rangeCheck(c.supportTexture, 0, 2048, "supportTexture");
  rangeCheck(c.supportMinRange, 0, c.dispMax, "supportMinRange");
  rangeCheck(c.inconWindowSize, 1, 16, "inconWindowSize");
  rangeCheck(c.inconThreshold, 0, c.dispMax, "inconThreshold");
  rangeCheck(c.inconMinSupport, 1, (2 * c.inconWindowSize + 1) * (2 * c.inconWindowSize + 1), "inconMinSupport");
  rangeCheck(c.lrThreshold, 0, c.dispMax, "lrThreshold");
  rangeCheck(c.supportThresholdPercent, 1, 100, "supportThresholdPercent");
  rangeCheck(c.fillEpsilon, 0, c.dispMax, "fillEpsilon");
  rangeCheck(c.sDelta, 0, 8192, "sDelta");
  rangeCheck(c.epsilon, 0, c.dispMax, "epsilon");
  rangeCheck(c.fillC, 0, c.dispMax, "fillC");
  if (c.parameterSet != "robotics" && c.parameterSet != "middlebury")
    throw std::runtime_error("configuration: parameterSet '" + c.parameterSet + "' is unknown (legal: robotics, middlebury)");
  if (c.fillRule != "r7" && c.fillRule != "paper")
    throw std::runtime_error("configuration: fillRule '" + c.fillRule + "' is unknown (legal: r7, paper)");
  if (c.gridKeep != "smallest" && c.gridKeep != "votes")
    throw std::runtime_error("configuration: gridKeep '" + c.gridKeep + "' is unknown (legal: smallest, votes)");
  if (c.gridCorners != "none" && c.gridCorners != "nearest")
    throw std::runtime_error("configuration: gridCorners '" + c.gridCorners + "' is unknown (legal: none, nearest)");
  if (static_cast<int>(c.priorTable.size()) != c.dispMax + 1)
    throw std::runtime_error("configuration: priorTable has " + std::to_string(c.priorTable.size()) +
                             " entries, dispMax + 1 = " + std::to_string(c.dispMax + 1) + " expected");
}

Config loadConfig(const std::string& nameOrFile) {
  if (endsWith(nameOrFile, ".json")) return readConfigFile(nameOrFile);
  if (nameOrFile.empty() || nameOrFile.find('/') != std::string::npos)
    throw std::runtime_error("unknown configuration '" + nameOrFile + "'");
  for (const std::string& dir : configDirs()) {
    std::string path = dir + "/" + nameOrFile + ".json";
    if (fileExists(path)) return readConfigFile(path);
  }
  throw std::runtime_error("unknown configuration '" + nameOrFile + "' (no " + nameOrFile +
                           ".json in $IELAS_CONFIG_DIR or golden/configs)");
}

Config presetConfig(const std::string& parameterSet, int dispMax, int width, int height) {
  Config c;
  if (parameterSet == "robotics") {
    c.supportThresholdPercent = 85; c.gamma = 3.0; c.sradius = 2.0; c.matchTexture = 1; c.addCorners = false;
    c.ipolGapWidth = 3; c.filterMedian = false; c.filterAdaptiveMean = true; c.postprocessOnlyLeft = true;
  } else if (parameterSet == "middlebury") {
    c.supportThresholdPercent = 95; c.gamma = 5.0; c.sradius = 3.0; c.matchTexture = 0; c.addCorners = true;
    c.ipolGapWidth = 5000; c.filterMedian = true; c.filterAdaptiveMean = false; c.postprocessOnlyLeft = false;
  } else {
    throw std::runtime_error("unknown preset '" + parameterSet + "' (legal: robotics, middlebury)");
  }
  c.name = "preset-" + parameterSet;
  c.parameterSet = parameterSet;
  c.maxWidth = width;
  c.maxHeight = height;
  c.dispMax = dispMax;
  c.windowSize = 5;
  c.storedDisparities = 20;
  c.candidateStep = 5;
  c.gridSize = 20;
  c.supportTexture = 10; c.supportMinRange = 10;
  c.inconWindowSize = 5; c.inconThreshold = 5; c.inconMinSupport = 5;
  c.lrThreshold = 2;
  c.beta = 0.02; c.sigma = 1.0;
  c.speckleSimThreshold = 1; c.speckleSize = 200; c.speckleWindowRows = 16; c.ipolColumnWindow = 32;
  c.fillRule = "r7"; c.fillEpsilon = 15; c.sDelta = 50; c.epsilon = 15; c.fillC = dispMax < 60 ? dispMax : 60;
  c.supportLanes = 0; c.denseLanes = 0;
  c.planeRadius = std::max(static_cast<int>(std::ceil(c.sigma * c.sradius)), 2);
  rangeCheck(dispMax, 1, 1023, "dispMax");
  c.priorTable = computePriorTable(dispMax, c.gamma, c.sigma, c.beta);
  deriveConfig(c);
  validateConfig(c);
  return c;
}

}  // namespace ielas
