#include "ielas/dense.hpp"
#include <stdexcept>

namespace ielas {

cv::Mat denseMatch(const cv::Mat&, const cv::Mat&, const Planes&, const Grid&, View, const Config&) {
  throw std::runtime_error("not implemented yet");
}

}  // namespace ielas
