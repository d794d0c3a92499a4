#include "ielas/postprocess.hpp"
#include <stdexcept>

namespace ielas {

cv::Mat postprocess(const cv::Mat&, const Config&) { throw std::runtime_error("not implemented yet"); }

}  // namespace ielas
