// The generator configuration, read from golden/configs/<name>.json (written by the Scala ElasParams).
// Field names are the JSON keys. Nothing here is typed twice: the JSON is the only source.
#pragma once
#include <string>
#include <vector>

namespace ielas {

struct Config {
  std::string name;
  int maxWidth = 0, maxHeight = 0;
  int dispMax = 0;
  int windowSize = 5;
  int storedDisparities = 20;
  int candidateStep = 5;
  int gridSize = 20;
  std::string parameterSet;  // "robotics" | "middlebury"
  int supportTexture = 10, supportMinRange = 10;
  int inconWindowSize = 5, inconThreshold = 5, inconMinSupport = 5;
  int lrThreshold = 2;
  double beta = 0.02, sigma = 1.0;
  int speckleSimThreshold = 1, speckleSize = 200, speckleWindowRows = 16;
  int ipolColumnWindow = 32;
  std::string fillRule;  // "r7" | "paper"
  int fillEpsilon = 15, sDelta = 50, epsilon = 15, fillC = 60;
  int supportLanes = 0, denseLanes = 0;
  // derived by ElasParams (recomputed by presetConfig)
  int supportThresholdPercent = 85;
  double gamma = 3.0, sradius = 2.0;
  int planeRadius = 2;
  int matchTexture = 1;
  bool addCorners = false;
  int ipolGapWidth = 3;
  bool filterMedian = false, filterAdaptiveMean = true, postprocessOnlyLeft = true;
  int descriptorBytes = 16, descriptorMargin = 3, supportMargin = 5;
  int latticeColsMax = 0, latticeRowsMax = 0, gridColsMax = 0, gridRowsMax = 0;
  std::vector<int> priorTable;  // P[delta], delta = 0..dispMax

  int windowRadius() const { return windowSize / 2; }
  // Lattice nodes along an axis of `pixels`: 0, step, 2 step, ... plus a last node at pixels-1 when off-step.
  int latticeCount(int pixels) const {
    return (pixels + candidateStep - 1) / candidateStep + ((pixels - 1) % candidateStep != 0 ? 1 : 0);
  }
  // Pixel coordinate of lattice index i along an axis of `pixels`.
  int latticeCoord(int i, int pixels) const {
    int c = i * candidateStep;
    return c < pixels ? c : pixels - 1;
  }
  int gridCount(int pixels) const { return (pixels + gridSize - 1) / gridSize; }
};

}  // namespace ielas
