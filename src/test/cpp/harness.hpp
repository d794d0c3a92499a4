// Pieces shared by the Verilator harness's modes: ielas_sim.cpp (one pair, N frames) and soak.cpp (a frame list
// with malformed frames, `make soak`). Option parsing helpers, the configuration's maximum frame size, and the
// Verilated IElas top with one function per clock cycle.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "VIElas.h"
#include "verilated.h"

#ifndef IELAS_SIM_CONFIG
#define IELAS_SIM_CONFIG ""
#endif
#ifndef IELAS_SIM_CONFIG_DIR
#define IELAS_SIM_CONFIG_DIR "golden/configs"
#endif

namespace harness {

[[noreturn]] inline void die(int code, const std::string& msg) {
  std::fflush(stdout);
  std::fprintf(stderr, "ielas_sim: %s\n", msg.c_str());
  std::exit(code);
}

inline long long parseInt(const std::string& opt, const std::string& v, long long lo, long long hi) {
  size_t used = 0;
  long long x = 0;
  try {
    x = std::stoll(v, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != v.size() || x < lo || x > hi)
    die(1, opt + " wants an integer in " + std::to_string(lo) + ".." + std::to_string(hi) + ", got '" + v + "'");
  return x;
}

inline double parseProb(const std::string& opt, const std::string& v) {
  size_t used = 0;
  double x = -1;
  try {
    x = std::stod(v, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != v.size() || !(x >= 0.0 && x < 1.0)) die(1, opt + " wants a probability in [0, 1), got '" + v + "'");
  return x;
}

// maxWidth/maxHeight of a configuration: a JSON file, or NAME looked up in $IELAS_CONFIG_DIR, then in the
// repository's golden/configs (compiled in by the build script).
inline void readConfigSize(const std::string& config, int& maxWidth, int& maxHeight) {
  std::string path = config;
  bool isFile = config.find('/') != std::string::npos ||
                (config.size() > 5 && config.compare(config.size() - 5, 5, ".json") == 0);
  if (!isFile) {
    const char* env = std::getenv("IELAS_CONFIG_DIR");
    std::string dir = env && *env ? env : IELAS_SIM_CONFIG_DIR;
    path = dir + "/" + config + ".json";
  }
  if (!std::filesystem::is_regular_file(path)) die(1, "unknown configuration '" + config + "' (no file " + path + ")");
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ | cv::FileStorage::FORMAT_JSON);
    cv::FileNode w = fs["maxWidth"], h = fs["maxHeight"];
    if (!w.isInt() || !h.isInt()) die(1, "configuration " + path + ": maxWidth/maxHeight missing or not integers");
    maxWidth = static_cast<int>(w);
    maxHeight = static_cast<int>(h);
  } catch (const cv::Exception&) {
    die(1, "configuration " + path + ": malformed JSON");
  }
}

// The smallest legal frame (FrameSize.isLegal in the RTL).
constexpr int kMinWidth = 32, kMinHeight = 16;

struct InBeat {
  uint8_t left = 0, right = 0;
  bool sof = false, eol = false;
};

// What one clock cycle saw, sampled with the clock low after the inputs were driven (so a transfer "at cycle c"
// is the one the rising edge of c completes).
struct Sample {
  bool inFire = false, outFire = false;
  int16_t data = 0;
  bool sof = false, eol = false, eof = false;
  bool error = false;       // the sticky error bit during this cycle
  unsigned causes = 0;      // errorCauses pulses (FrameGuard.Cause bits)
  bool aborted = false;     // frameAborted pulse
  bool cleared = false;     // clearError was driven in this cycle
};

// The Verilated IElas top. Only '+' arguments reach the model, so its $value$plusargs never sees our options.
class Dut {
 public:
  Dut(const char* argv0, const std::vector<std::string>& plusargs) : ctx_(std::make_unique<VerilatedContext>()) {
    args_.push_back(argv0);
    for (const auto& p : plusargs) args_.push_back(p);
    for (const auto& s : args_) argv_.push_back(s.c_str());
    ctx_->commandArgs(static_cast<int>(argv_.size()), argv_.data());
    top_ = std::make_unique<VIElas>(ctx_.get());
  }

  bool finished() const { return ctx_->gotFinish(); }
  uint64_t clocks() const { return clocks_; }  // every rising edge, reset included
  bool error() const { return top_->io_error; }
  void final() { top_->final(); }

  void reset(int cycles, int width, int height) {
    top_->io_frameWidth = width;
    top_->io_frameHeight = height;
    top_->io_clearError = 0;
    top_->io_in_valid = 0;
    top_->io_out_ready = 0;
    top_->reset = 1;
    for (int i = 0; i < cycles; ++i) edge();
    top_->reset = 0;
  }

  // One clock cycle. `clearOnError`: pulse clearError in this cycle when the error bit is set (the bit is a
  // register, so reading it before driving clearError is exact).
  Sample step(bool inValid, const InBeat& in, bool outReady, int width, int height, bool clearOnError = false) {
    top_->io_in_valid = inValid;
    top_->io_in_bits_left = in.left;
    top_->io_in_bits_right = in.right;
    top_->io_in_bits_sof = in.sof;
    top_->io_in_bits_eol = in.eol;
    top_->io_frameWidth = width;
    top_->io_frameHeight = height;
    top_->io_out_ready = outReady;
    top_->io_clearError = 0;
    top_->clock = 0;
    top_->eval();
    Sample s;
    s.inFire = top_->io_in_valid && top_->io_in_ready;
    s.outFire = top_->io_out_valid && top_->io_out_ready;
    s.data = static_cast<int16_t>(top_->io_out_bits_data);
    s.sof = top_->io_out_bits_sof;
    s.eol = top_->io_out_bits_eol;
    s.eof = top_->io_out_bits_eof;
    s.error = top_->io_error;
    s.causes = top_->io_errorCauses;
    s.aborted = top_->io_frameAborted;
    if (clearOnError && s.error) {
      top_->io_clearError = 1;
      top_->eval();
      s.cleared = true;
    }
    top_->clock = 1;
    top_->eval();
    ++clocks_;
    return s;
  }

 private:
  void edge() {
    top_->clock = 0;
    top_->eval();
    top_->clock = 1;
    top_->eval();
    ++clocks_;
  }

  std::unique_ptr<VerilatedContext> ctx_;
  std::unique_ptr<VIElas> top_;
  std::vector<std::string> args_;
  std::vector<const char*> argv_;
  uint64_t clocks_ = 0;
};

// The soak modes (soak.cpp), dispatched from ielas_sim's main by their first argument.
int soakPlanMain(int argc, char** argv);
int soakMain(int argc, char** argv);

}  // namespace harness
