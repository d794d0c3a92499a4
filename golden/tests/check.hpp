// Minimal test helpers: CHECK / CHECK_EQ count failures and keep going; main returns testExitCode().
#pragma once
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace testing_detail {
inline int& failures() {
  static int n = 0;
  return n;
}
inline int& checks() {
  static int n = 0;
  return n;
}
}  // namespace testing_detail

#define CHECK(cond)                                                                       \
  do {                                                                                    \
    ++testing_detail::checks();                                                           \
    if (!(cond)) {                                                                        \
      ++testing_detail::failures();                                                       \
      std::cerr << __FILE__ << ":" << __LINE__ << ": CHECK failed: " #cond << std::endl; \
    }                                                                                     \
  } while (0)

#define CHECK_EQ(actual, expected)                                                                        \
  do {                                                                                                    \
    ++testing_detail::checks();                                                                           \
    auto check_a_ = (actual);                                                                             \
    auto check_e_ = (expected);                                                                           \
    if (!(check_a_ == check_e_)) {                                                                        \
      ++testing_detail::failures();                                                                       \
      std::cerr << __FILE__ << ":" << __LINE__ << ": CHECK_EQ failed: " #actual " = " << +check_a_        \
                << ", expected " << +check_e_ << std::endl;                                               \
    }                                                                                                     \
  } while (0)

// Expects `expr` to throw std::runtime_error whose message contains `fragment`.
#define CHECK_THROWS(expr, fragment)                                                                     \
  do {                                                                                                   \
    ++testing_detail::checks();                                                                          \
    bool check_thrown_ = false;                                                                          \
    try {                                                                                                \
      (void)(expr);                                                                                      \
    } catch (const std::runtime_error& e) {                                                              \
      check_thrown_ = std::string(e.what()).find(fragment) != std::string::npos;                        \
      if (!check_thrown_) std::cerr << "  (message was: " << e.what() << ")" << std::endl;               \
    }                                                                                                    \
    if (!check_thrown_) {                                                                                \
      ++testing_detail::failures();                                                                      \
      std::cerr << __FILE__ << ":" << __LINE__ << ": CHECK_THROWS failed: " #expr " / " fragment << std::endl; \
    }                                                                                                    \
  } while (0)

// Counts a failed check whose caller has printed its own message (a value mismatch with context, a missing column).
inline void recordFailure() {
  ++testing_detail::checks();
  ++testing_detail::failures();
}
inline bool anyFailed() { return testing_detail::failures() != 0; }

inline int testExitCode(const char* name) {
  int f = testing_detail::failures();
  std::cout << name << ": " << testing_detail::checks() << " checks, " << f << " failed" << std::endl;
  return f == 0 ? 0 : 1;
}
