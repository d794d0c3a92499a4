// `match --mode elas`: libelas's Elas::process at full resolution, stage by stage (docs/ALGORITHM.md, elas mode).
#include "ielas/elas.hpp"

#include <stdexcept>

#include "ielas/descriptor.hpp"

namespace ielas {

cv::Mat elasMatch(const cv::Mat& left8, const cv::Mat& right8, const Config& cfg) {
  if (left8.type() != CV_8U || right8.type() != CV_8U) throw std::runtime_error("elas: inputs must be 8-bit grey");
  if (left8.size() != right8.size()) throw std::runtime_error("elas: left and right images differ in size");
  const int width = left8.cols, height = left8.rows;

  const cv::Mat descL = computeDescriptor(left8, cfg), descR = computeDescriptor(right8, cfg);
  cv::Mat lattice = elas::supportLattice(descL, descR, cfg);
  elas::removeInconsistentSupport(lattice, cfg);
  // Points on straight lines are redundant: libelas drops them, vertical pass first (distance 5, tolerance 1).
  elas::removeRedundantSupport(lattice, 5, 1, true);
  elas::removeRedundantSupport(lattice, 5, 1, false);
  const std::vector<elas::SupportPoint> points = elas::supportList(lattice, width, height, cfg);
  // libelas returns without writing the maps below 3 support points; here the map is then all invalid.
  if (points.size() < 3) return cv::Mat(height, width, CV_32F, cv::Scalar(elas::kInvalid));

  std::vector<elas::Triangle> trianglesL = elas::triangulateSupport(points, View::Left);
  std::vector<elas::Triangle> trianglesR = elas::triangulateSupport(points, View::Right);
  elas::computePlanes(points, trianglesL, View::Left);
  elas::computePlanes(points, trianglesR, View::Right);
  const elas::CandidateGrid gridL = elas::candidateGrid(points, width, height, View::Left, cfg);
  const elas::CandidateGrid gridR = elas::candidateGrid(points, width, height, View::Right, cfg);

  cv::Mat dispL = elas::denseMatching(descL, descR, points, trianglesL, gridL, View::Left, cfg);
  cv::Mat dispR = elas::denseMatching(descL, descR, points, trianglesR, gridR, View::Right, cfg);
  elas::leftRightConsistency(dispL, dispR, cfg);

  // Only the left map is returned, so the right map's own post-processing (MIDDLEBURY) is skipped: it cannot
  // change the left output.
  elas::removeSmallSegments(dispL, cfg);
  elas::gapInterpolation(dispL, cfg);
  if (cfg.filterAdaptiveMean) elas::adaptiveMean(dispL);
  if (cfg.filterMedian) elas::median(dispL);
  return dispL;
}

}  // namespace ielas
