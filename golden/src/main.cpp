// ielas-golden: the command line of docs/interfaces.md §2 (match, dump).
#include <chrono>
#include <ctime>
#include <cstdio>
#include <iostream>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "ielas/config.hpp"
#include "ielas/elas.hpp"
#include "ielas/ielas.hpp"
#include "ielas/image_io.hpp"

using namespace ielas;

namespace {

const char* kUsage =
    "usage: ielas-golden match --mode elas|ielas (--preset robotics|middlebury [--disp-max N] | --config NAME|FILE.json)\n"
    "                          --left L --right R --out D.pfm|D.png [--interp paper|r7] [--sdelta PX] [--epsilon E]\n"
    "                          [--fill-c C] [--grid-keep smallest|votes] [--grid-corners none|nearest] [--time]\n"
    "       ielas-golden dump  --mode ielas (--preset ... | --config ...) --left L --right R --out DIR [same options]\n"
    "       ielas-golden config (--preset robotics|middlebury [--disp-max N] --width W --height H | --config NAME|FILE.json)\n"
    "                          [--set KEY=VALUE]... [--print] [--try KEY=VALUE]...\n"
    "                          (load and check a configuration; --print writes it; each --try prints 'ok' or the error\n"
    "                          of that one change to it, one line each)\n";

bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// A decimal integer in lo..hi; anything else (a fraction, an exponent, a number that does not fit) is refused
// with the legal range instead of being wrapped or clamped.
int parseInt(const std::string& option, const std::string& text, long long lo, long long hi) {
  size_t at = text.size() > 1 && text[0] == '-' ? 1 : 0;
  bool ok = at < text.size() && text.size() - at <= 10;
  long long v = 0;
  for (size_t i = at; ok && i < text.size(); ++i) {
    ok = text[i] >= '0' && text[i] <= '9';
    v = v * 10 + (text[i] - '0');
  }
  if (at == 1) v = -v;
  if (!ok || v < lo || v > hi)
    throw std::runtime_error(option + " " + (text.empty() ? "''" : text) + " is not an integer in " +
                             std::to_string(lo) + ".." + std::to_string(hi));
  return static_cast<int>(v);
}

// The integer options and their ranges (--epsilon and --fill-c are checked against dispMax by validateConfig).
const std::map<std::string, std::pair<int, int>> kIntOptions = {
    {"--disp-max", {1, 1023}}, {"--sdelta", {0, 8192}}, {"--epsilon", {0, 1023}}, {"--fill-c", {0, 1023}}};

struct Options {
  std::string command;
  std::map<std::string, std::string> values;
  bool time = false;
  bool has(const std::string& k) const { return values.count(k) != 0; }
  const std::string& get(const std::string& k) const {
    auto it = values.find(k);
    if (it == values.end()) throw std::runtime_error("missing option " + k);
    return it->second;
  }
};

int intOption(const Options& o, const std::string& option) {
  const auto& range = kIntOptions.at(option);
  return parseInt(option, o.get(option), range.first, range.second);
}

Options parseArgs(int argc, char** argv) {
  static const std::set<std::string> withValue = {"--mode", "--preset", "--disp-max", "--config", "--left", "--right",
                                                  "--out", "--interp", "--sdelta", "--epsilon", "--fill-c", "--grid-keep", "--grid-corners"};
  if (argc < 2) throw std::runtime_error("missing command (match or dump); run ielas-golden --help");
  Options o;
  o.command = argv[1];
  if (o.command != "match" && o.command != "dump")
    throw std::runtime_error("unknown command '" + o.command + "' (legal: match, dump, config)");
  for (int i = 2; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--time") {
      o.time = true;
    } else if (withValue.count(a)) {
      if (i + 1 >= argc) throw std::runtime_error("option " + a + " needs a value");
      if (o.values.count(a)) throw std::runtime_error("option " + a + " given twice");
      o.values[a] = argv[++i];
    } else {
      throw std::runtime_error("unknown option '" + a + "'");
    }
  }
  return o;
}

Config buildConfig(const Options& o, const cv::Mat& left) {
  Config cfg;
  if (o.has("--preset")) {
    const std::string& set = o.get("--preset");
    int dispMax = o.has("--disp-max") ? intOption(o, "--disp-max") : 255;
    cfg = presetConfig(set, dispMax, left.cols, left.rows);
  } else {
    cfg = loadConfig(o.get("--config"));
  }
  if (o.has("--interp")) {
    const std::string& rule = o.get("--interp");
    if (rule != "paper" && rule != "r7") throw std::runtime_error("unknown --interp '" + rule + "' (legal: paper, r7)");
    cfg.fillRule = rule;
  }
  if (o.has("--sdelta")) cfg.sDelta = intOption(o, "--sdelta");
  if (o.has("--epsilon")) cfg.epsilon = intOption(o, "--epsilon");
  if (o.has("--fill-c")) cfg.fillC = intOption(o, "--fill-c");
  if (o.has("--grid-keep")) cfg.gridKeep = o.get("--grid-keep");
  if (o.has("--grid-corners")) cfg.gridCorners = o.get("--grid-corners");
  validateConfig(cfg);
  return cfg;
}

void writeDisparity(const std::string& out, const cv::Mat& disparity) {
  if (endsWith(out, ".pfm")) writePfm(out, disparity);
  else writeKittiPng(out, disparity);
}

// `config`: loads a configuration (a --preset with a frame size, or --config), applies each --set KEY=VALUE to the
// card parameters in order (re-deriving and checking every rule after each), and prints nothing (exit 0) or, with
// --print, the result as JSON. An illegal configuration is the usual one-line error and exit 1. Each --try KEY=VALUE
// is applied alone to a copy of the result and prints one line: "ok" or its error (exit 0 either way).
int runConfig(int argc, char** argv) {
  std::map<std::string, std::string> values;
  std::vector<std::string> sets, tries;
  bool print = false;
  for (int i = 2; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--print") {
      print = true;
    } else if (a == "--preset" || a == "--disp-max" || a == "--config" || a == "--width" || a == "--height" || a == "--set" ||
               a == "--try") {
      if (i + 1 >= argc) throw std::runtime_error("option " + a + " needs a value");
      if (a == "--set") sets.push_back(argv[++i]);
      else if (a == "--try") tries.push_back(argv[++i]);
      else if (!values.emplace(a, argv[++i]).second) throw std::runtime_error("option " + a + " given twice");
    } else {
      throw std::runtime_error("unknown option '" + a + "'");
    }
  }
  if (values.count("--preset") == values.count("--config")) throw std::runtime_error("give exactly one of --preset and --config");
  Config cfg;
  if (values.count("--config")) {
    if (values.count("--disp-max") || values.count("--width") || values.count("--height"))
      throw std::runtime_error("--disp-max, --width and --height go with --preset only");
    cfg = loadConfig(values["--config"]);
  } else {
    if (!values.count("--width") || !values.count("--height")) throw std::runtime_error("--preset needs --width and --height");
    int dispMax = values.count("--disp-max") ? parseInt("--disp-max", values["--disp-max"], 1, 1023) : 255;
    cfg = presetConfig(values["--preset"], dispMax, parseInt("--width", values["--width"], 1, 8192),
                       parseInt("--height", values["--height"], 1, 8192));
  }
  auto apply = [](Config& c, const std::string& option, const std::string& kv) {
    size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) throw std::runtime_error(option + " " + kv + " is not KEY=VALUE");
    overrideConfig(c, kv.substr(0, eq), kv.substr(eq + 1));
  };
  for (const std::string& kv : sets) apply(cfg, "--set", kv);
  if (print) std::cout << configToJson(cfg);
  for (const std::string& kv : tries) {
    Config c = cfg;
    try {
      apply(c, "--try", kv);
      std::cout << "ok\n";
    } catch (const std::exception& e) {
      std::string msg = e.what();
      for (char& ch : msg)
        if (ch == '\n') ch = ' ';
      std::cout << msg << "\n";
    }
  }
  return 0;
}

int run(int argc, char** argv) {
  if (argc >= 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h" || std::string(argv[1]) == "help")) {
    std::cout << kUsage;
    return 0;
  }
  if (argc >= 2 && std::string(argv[1]) == "config") return runConfig(argc, argv);
  Options o = parseArgs(argc, argv);
  const std::string& mode = o.get("--mode");
  if (mode != "elas" && mode != "ielas") throw std::runtime_error("unknown --mode '" + mode + "' (legal: elas, ielas)");
  if (o.command == "dump" && mode != "ielas") throw std::runtime_error("dump supports --mode ielas only");
  if (o.has("--preset") == o.has("--config")) throw std::runtime_error("give exactly one of --preset and --config");
  if (o.has("--disp-max") && !o.has("--preset")) throw std::runtime_error("--disp-max goes with --preset only");
  const std::string& out = o.get("--out");
  if (o.command == "match" && !endsWith(out, ".pfm") && !endsWith(out, ".png"))
    throw std::runtime_error("--out must end in .pfm or .png");
  if (o.has("--preset")) presetFile(o.get("--preset"));  // an unknown preset before any image is read
  for (const auto& option : kIntOptions)  // number errors before any image is read
    if (o.has(option.first)) intOption(o, option.first);
  // The configuration first (its errors do not depend on the images), except for --preset, which needs the size.
  Config cfg;
  if (o.has("--config")) cfg = loadConfig(o.get("--config"));
  cv::Mat left = loadGray8(o.get("--left"));
  cv::Mat right = loadGray8(o.get("--right"));
  // Mismatch and the 32x16 minimum first: --preset derives its maximum from the frame itself.
  checkPairSize(left, right, o.has("--config") ? cfg.maxWidth : 8192, o.has("--config") ? cfg.maxHeight : 8192,
                o.has("--config") ? "configuration " + cfg.name : "--preset");
  cfg = buildConfig(o, left);
  checkPairSize(left, right, cfg.maxWidth, cfg.maxHeight, "configuration " + cfg.name);
  cv::setNumThreads(1);  // single-threaded timings, like libelas

  auto start = std::chrono::steady_clock::now();
  const std::clock_t cpuStart = std::clock();
  cv::Mat disparity;
  std::vector<std::pair<std::string, double>> stageMs;
  if (mode == "elas") {
    disparity = elasMatch(left, right, cfg);
  } else {
    IelasFrame f = runIelas(left, right, cfg);
    stageMs = f.stageMs;
    if (o.command == "dump") {
      dumpIelas(f, out);
      if (!f.lateError.empty()) std::cerr << "note: late stages skipped: " << f.lateError << "\n";
      return 0;
    }
    if (!f.hasDisparity) throw std::runtime_error(f.lateError.empty() ? "not implemented yet" : f.lateError);
    disparity = disparityToFloat(f.disparity);
  }
  auto stop = std::chrono::steady_clock::now();
  // CPU time beside wall time: on a shared machine the process's own CPU time is the steadier number.
  if (o.time)
    std::printf("time per frame: %.1f ms (cpu %.1f ms, %s, %dx%d)\n",
                std::chrono::duration<double, std::milli>(stop - start).count(),
                1000.0 * static_cast<double>(std::clock() - cpuStart) / CLOCKS_PER_SEC, mode.c_str(), left.cols, left.rows);
  if (o.time && !stageMs.empty()) {  // after the total: scripts read the first timing line
    std::printf("stages (cpu):");
    for (const auto& st : stageMs) std::printf(" %s %.1f ms;", st.first.c_str(), st.second);
    std::printf("\n");
  }
  writeDisparity(out, disparity);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::string msg = e.what();
    for (char& c : msg)
      if (c == '\n') c = ' ';  // always exactly one line
    std::cerr << "ielas-golden: error: " << msg << "\n";
    return 1;
  }
}
