#include "ielas/elas.hpp"
#include <stdexcept>

namespace ielas {

cv::Mat elasMatch(const cv::Mat& left8, const cv::Mat& right8, const Config& cfg) {
  (void)left8; (void)right8; (void)cfg;
  throw std::runtime_error("not implemented yet");
}

}  // namespace ielas
