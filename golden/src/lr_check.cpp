#include "ielas/lr_check.hpp"
#include <stdexcept>

namespace ielas {

void lrCheck(const cv::Mat&, const cv::Mat&, cv::Mat&, cv::Mat&, const Config&) {
  throw std::runtime_error("not implemented yet");
}

}  // namespace ielas
