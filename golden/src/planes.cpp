#include "ielas/planes.hpp"
#include <stdexcept>

namespace ielas {

Planes computePlanes(const cv::Mat&, int, int, const Config&) { throw std::runtime_error("not implemented yet"); }
std::vector<int32_t> planesDump(const Planes&, View, std::vector<int>&) { throw std::runtime_error("not implemented yet"); }
const Plane* planeAt(const Planes&, View, int, int) { throw std::runtime_error("not implemented yet"); }
int planeValue(const Plane&, int, int) { throw std::runtime_error("not implemented yet"); }

}  // namespace ielas
