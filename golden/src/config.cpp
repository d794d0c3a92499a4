// Configuration loading (golden/configs/<name>.json from ElasParams) and the --preset configuration.
#include "ielas/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
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

// The card parameters (the fields of ElasParams but the name): each must have a rule in the JSON's "legal" object.
struct IntKey { const char* key; int Config::*field; };
struct RealKey { const char* key; double Config::*field; };
struct NameKey { const char* key; std::string Config::*field; };
const IntKey kCardInts[] = {
    {"maxWidth", &Config::maxWidth}, {"maxHeight", &Config::maxHeight}, {"dispMax", &Config::dispMax},
    {"windowSize", &Config::windowSize}, {"storedDisparities", &Config::storedDisparities},
    {"candidateStep", &Config::candidateStep}, {"gridSize", &Config::gridSize},
    {"supportTexture", &Config::supportTexture}, {"supportMinRange", &Config::supportMinRange},
    {"inconWindowSize", &Config::inconWindowSize}, {"inconThreshold", &Config::inconThreshold},
    {"inconMinSupport", &Config::inconMinSupport}, {"lrThreshold", &Config::lrThreshold},
    {"speckleSimThreshold", &Config::speckleSimThreshold}, {"speckleSize", &Config::speckleSize},
    {"speckleWindowRows", &Config::speckleWindowRows}, {"ipolColumnWindow", &Config::ipolColumnWindow},
    {"fillEpsilon", &Config::fillEpsilon}, {"sDelta", &Config::sDelta}, {"epsilon", &Config::epsilon},
    {"fillC", &Config::fillC}, {"cyclesPerPixel", &Config::cyclesPerPixel}, {"supportLanes", &Config::supportLanes},
    {"denseLanes", &Config::denseLanes}};
const RealKey kCardReals[] = {{"beta", &Config::beta}, {"sigma", &Config::sigma}};
const NameKey kCardNames[] = {{"parameterSet", &Config::parameterSet}, {"fillRule", &Config::fillRule}};
// Values ElasParams derives (from the parameter set and the card parameters).
const IntKey kDerivedInts[] = {
    {"supportThresholdPercent", &Config::supportThresholdPercent}, {"planeRadius", &Config::planeRadius},
    {"matchTexture", &Config::matchTexture}, {"ipolGapWidth", &Config::ipolGapWidth},
    {"descriptorBytes", &Config::descriptorBytes}, {"descriptorMargin", &Config::descriptorMargin},
    {"supportMargin", &Config::supportMargin}, {"latticeColsMax", &Config::latticeColsMax},
    {"latticeRowsMax", &Config::latticeRowsMax}, {"gridColsMax", &Config::gridColsMax},
    {"gridRowsMax", &Config::gridRowsMax}};
const RealKey kDerivedReals[] = {{"gamma", &Config::gamma}, {"sradius", &Config::sradius}};
struct BoolKey { const char* key; bool Config::*field; };
const BoolKey kDerivedBools[] = {{"addCorners", &Config::addCorners}, {"filterMedian", &Config::filterMedian},
                                 {"filterAdaptiveMean", &Config::filterAdaptiveMean},
                                 {"postprocessOnlyLeft", &Config::postprocessOnlyLeft}};

const IntKey* findInt(const std::string& key) {
  for (const IntKey& k : kCardInts)
    if (key == k.key) return &k;
  return nullptr;
}
const RealKey* findReal(const std::string& key) {
  for (const RealKey& k : kCardReals)
    if (key == k.key) return &k;
  return nullptr;
}
const NameKey* findName(const std::string& key) {
  for (const NameKey& k : kCardNames)
    if (key == k.key) return &k;
  return nullptr;
}

std::vector<LegalRule> readLegal(const cv::FileStorage& fs, const std::string& path) {
  const std::string where = "configuration " + path + ": ";
  cv::FileNode n = fs["legal"];
  if (n.isNone())
    throw std::runtime_error(where + "missing key 'legal' (the legal values of the parameters; write the file with make configs)");
  if (!n.isMap()) throw std::runtime_error(where + "key 'legal' is not an object");
  std::vector<LegalRule> rules;
  for (cv::FileNodeIterator it = n.begin(); it != n.end(); ++it) {
    cv::FileNode entry = *it;
    const std::string param = entry.name();
    if (!findInt(param) && !findReal(param) && !findName(param))
      throw std::runtime_error(where + "legal entry '" + param + "' names no card parameter");
    if (!entry.isSeq() || entry.size() == 0) throw std::runtime_error(where + "legal entry '" + param + "' is not a list of rules");
    for (const cv::FileNode& r : entry) {
      if (!r.isSeq() || r.size() < 2 || !r[0].isString())
        throw std::runtime_error(where + "legal entry '" + param + "' holds a rule that is not [\"kind\", ...]");
      LegalRule rule;
      rule.param = param;
      rule.kind = static_cast<std::string>(r[0]);
      if (rule.kind != "range" && rule.kind != "aboveUpTo" && rule.kind != "oneOf" && rule.kind != "zeroOrPowerOfTwo")
        throw std::runtime_error(where + "legal entry '" + param + "' has an unknown rule '" + rule.kind + "'");
      if (rule.kind != "oneOf" && r.size() != 3)
        throw std::runtime_error(where + "legal entry '" + param + "': rule '" + rule.kind + "' takes two bounds");
      for (size_t i = 1; i < r.size(); ++i) {
        LegalArg a;
        if (r[i].isString()) {
          a.isString = true;
          a.text = static_cast<std::string>(r[i]);
        } else if (r[i].isInt() || r[i].isReal()) {
          a.number = static_cast<double>(r[i]);
        } else {
          throw std::runtime_error(where + "legal entry '" + param + "' holds a value that is neither a number nor a string");
        }
        rule.args.push_back(a);
      }
      rules.push_back(rule);
    }
  }
  auto has = [&](const char* key) {
    return std::any_of(rules.begin(), rules.end(), [&](const LegalRule& r) { return r.param == key; });
  };
  for (const IntKey& k : kCardInts)
    if (!has(k.key)) throw std::runtime_error(where + "no legal entry for '" + k.key + "'");
  for (const RealKey& k : kCardReals)
    if (!has(k.key)) throw std::runtime_error(where + "no legal entry for '" + k.key + "'");
  for (const NameKey& k : kCardNames)
    if (!has(k.key)) throw std::runtime_error(where + "no legal entry for '" + k.key + "'");
  return rules;
}

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
  for (const IntKey& k : kCardInts) r.readInt(k.key, c.*k.field);
  for (const RealKey& k : kCardReals) r.readDouble(k.key, c.*k.field);
  for (const NameKey& k : kCardNames) r.readString(k.key, c.*k.field);
  for (const IntKey& k : kDerivedInts) r.readInt(k.key, c.*k.field);
  for (const RealKey& k : kDerivedReals) r.readDouble(k.key, c.*k.field);
  for (const BoolKey& k : kDerivedBools) r.readBool(k.key, c.*k.field);
  r.readIntList("priorTable", c.priorTable);
  r.readString("gridKeep", c.gridKeep, false);
  r.readString("gridCorners", c.gridCorners, false);
  c.legal = readLegal(fs, path);
  cv::FileNode follows = fs["presetFollows"];
  if (!follows.isNone()) {
    if (!follows.isSeq()) throw std::runtime_error("configuration " + path + ": key 'presetFollows' is not a list");
    for (const cv::FileNode& f : follows) {
      if (!f.isString() || !findInt(static_cast<std::string>(f)))
        throw std::runtime_error("configuration " + path + ": 'presetFollows' holds a name of no integer card parameter");
      c.presetFollows.push_back(static_cast<std::string>(f));
    }
  }
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

int intParam(const Config& c, const std::string& key, const std::string& rule) {
  const IntKey* k = findInt(key);
  if (!k) throw std::runtime_error("configuration: the legal rule of " + rule + " names no integer parameter '" + key + "'");
  return c.*k->field;
}

// A bound: a number, "NAME", "NAME+K", "NAME-K" or "(2*NAME+1)^2".
long long boundValue(const Config& c, const LegalArg& a, const std::string& param) {
  if (!a.isString) return static_cast<long long>(a.number);
  const std::string& t = a.text;
  const std::string head = "(2*", tail = "+1)^2";
  if (t.size() > head.size() + tail.size() && t.compare(0, head.size(), head) == 0 && endsWith(t, tail)) {
    long long n = 2LL * intParam(c, t.substr(head.size(), t.size() - head.size() - tail.size()), param) + 1;
    return n * n;
  }
  size_t op = t.find_first_of("+-");
  long long k = 0;
  if (op != std::string::npos) {
    const std::string digits = t.substr(op + 1);
    if (digits.empty() || digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos)
      throw std::runtime_error("configuration: the legal rule of " + param + " has a malformed bound '" + t + "'");
    k = std::stoll(digits) * (t[op] == '-' ? -1 : 1);
  }
  return intParam(c, t.substr(0, op), param) + k;
}

std::string formatReal(double x) {
  std::ostringstream os;
  os << x;
  return os.str();
}

std::string joinArgs(const std::vector<std::string>& xs) {
  std::string out;
  for (const std::string& x : xs) out += (out.empty() ? "" : ", ") + x;
  return out;
}

void checkRule(const Config& c, const LegalRule& rule) {
  const std::string& p = rule.param;
  const std::string prefix = "configuration: " + p;
  if (rule.kind == "aboveUpTo") {
    const RealKey* k = findReal(p);
    if (!k || rule.args[0].isString || rule.args[1].isString)
      throw std::runtime_error(prefix + ": rule aboveUpTo needs a real parameter and numeric bounds");
    double v = c.*k->field, lo = rule.args[0].number, hi = rule.args[1].number;
    if (!(v > lo && v <= hi))
      throw std::runtime_error(prefix + " = " + formatReal(v) + " is out of range (legal: (" + formatReal(lo) + ", " +
                               formatReal(hi) + "])");
    return;
  }
  if (rule.kind == "oneOf") {
    std::vector<std::string> legal;
    for (const LegalArg& a : rule.args) legal.push_back(a.isString ? a.text : std::to_string(static_cast<long long>(a.number)));
    if (const NameKey* k = findName(p)) {
      const std::string& v = c.*k->field;
      if (std::find(legal.begin(), legal.end(), v) == legal.end())
        throw std::runtime_error(prefix + " '" + v + "' is unknown (legal: " + joinArgs(legal) + ")");
      return;
    }
    const std::string v = std::to_string(intParam(c, p, p));
    if (std::find(legal.begin(), legal.end(), v) == legal.end())
      throw std::runtime_error(prefix + " = " + v + " is not supported (legal: " + joinArgs(legal) + ")");
    return;
  }
  long long v = intParam(c, p, p), lo = boundValue(c, rule.args[0], p), hi = boundValue(c, rule.args[1], p);
  if (rule.kind == "range") {
    if (v < lo || v > hi)
      throw std::runtime_error(prefix + " = " + std::to_string(v) + " is out of range (legal: " + std::to_string(lo) +
                               ".." + std::to_string(hi) + ")");
    return;
  }
  // zeroOrPowerOfTwo
  if (v != 0 && !(v >= lo && v <= hi && (v & (v - 1)) == 0)) {
    std::vector<std::string> legal = {"0"};
    for (long long x = 1; x <= hi; x *= 2)
      if (x >= lo) legal.push_back(std::to_string(x));
    throw std::runtime_error(prefix + " = " + std::to_string(v) + " is not supported (legal: " + joinArgs(legal) + ")");
  }
}

// Every rule of cfg.legal, in order.
void checkLegal(const Config& c) {
  if (c.legal.empty())
    throw std::runtime_error("configuration " + c.name + ": no legal values (a configuration JSON from ElasParams has a 'legal' object)");
  for (const LegalRule& rule : c.legal) checkRule(c, rule);
}

// After a card parameter changed: the rules first (the prior table's length follows dispMax), then the derived values.
void rederive(Config& c) {
  checkLegal(c);
  deriveConfig(c);
  c.planeRadius = std::max(static_cast<int>(std::ceil(c.sigma * c.sradius)), 2);
  c.priorTable = computePriorTable(c.dispMax, c.gamma, c.sigma, c.beta);
  validateConfig(c);
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
  checkLegal(c);
  // Golden-model-only knobs (not generator parameters).
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

std::string presetFile(const std::string& parameterSet) {
  std::vector<std::string> legal;
  for (const std::string& dir : configDirs()) {
    const std::string presets = dir + "/presets";
    if (!parameterSet.empty() && parameterSet.find('/') == std::string::npos && fileExists(presets + "/" + parameterSet + ".json"))
      return presets + "/" + parameterSet + ".json";
    std::error_code ec;
    if (legal.empty() && std::filesystem::is_directory(presets, ec)) {
      for (const auto& e : std::filesystem::directory_iterator(presets, ec))
        if (e.path().extension() == ".json") legal.push_back(e.path().stem().string());
      std::sort(legal.begin(), legal.end());
    }
  }
  throw std::runtime_error("unknown preset '" + parameterSet + "' (legal: " +
                           (legal.empty() ? std::string("none found; run make configs") : joinArgs(legal)) + ")");
}

Config presetConfig(const std::string& parameterSet, int dispMax, int width, int height) {
  Config c = readConfigFile(presetFile(parameterSet));
  c.name = "preset-" + parameterSet;
  c.maxWidth = width;
  c.maxHeight = height;
  c.dispMax = dispMax;
  for (const std::string& f : c.presetFollows) {
    int& v = c.*findInt(f)->field;
    for (const LegalRule& rule : c.legal)
      if (rule.param == f && rule.kind == "range")
        v = static_cast<int>(std::min<long long>(std::max<long long>(v, boundValue(c, rule.args[0], f)), boundValue(c, rule.args[1], f)));
  }
  rederive(c);
  return c;
}

void overrideConfig(Config& cfg, const std::string& key, const std::string& value) {
  Config c = cfg;  // cfg is left as it was when the change is illegal
  if (const IntKey* k = findInt(key)) {
    size_t at = value.size() > 1 && value[0] == '-' ? 1 : 0;
    if (at >= value.size() || value.size() - at > 10 || value.find_first_not_of("0123456789", at) != std::string::npos ||
        std::stoll(value) < std::numeric_limits<int>::min() || std::stoll(value) > std::numeric_limits<int>::max())
      throw std::runtime_error("configuration: " + key + " = " + value + " is not an integer");
    c.*k->field = static_cast<int>(std::stoll(value));
  } else if (const RealKey* k = findReal(key)) {
    char* end = nullptr;
    double v = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || !std::isfinite(v))
      throw std::runtime_error("configuration: " + key + " = " + value + " is not a number");
    c.*k->field = v;
  } else if (const NameKey* k = findName(key)) {
    c.*k->field = value;
  } else {
    throw std::runtime_error("configuration: unknown parameter '" + key + "'");
  }
  rederive(c);
  cfg = c;
}

std::string configToJson(const Config& c) {
  std::ostringstream os;
  os.precision(17);
  os << "{\n  \"name\": \"" << c.name << "\"";
  for (const IntKey& k : kCardInts) os << ",\n  \"" << k.key << "\": " << c.*k.field;
  for (const RealKey& k : kCardReals) os << ",\n  \"" << k.key << "\": " << c.*k.field;
  for (const NameKey& k : kCardNames) os << ",\n  \"" << k.key << "\": \"" << c.*k.field << "\"";
  for (const IntKey& k : kDerivedInts) os << ",\n  \"" << k.key << "\": " << c.*k.field;
  for (const RealKey& k : kDerivedReals) os << ",\n  \"" << k.key << "\": " << c.*k.field;
  for (const BoolKey& k : kDerivedBools) os << ",\n  \"" << k.key << "\": " << (c.*k.field ? 1 : 0);
  os << ",\n  \"priorTable\": [";
  for (size_t i = 0; i < c.priorTable.size(); ++i) os << (i ? ", " : "") << c.priorTable[i];
  os << "]\n}\n";
  return os.str();
}

}  // namespace ielas
