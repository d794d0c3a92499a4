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
  // Golden-model-only knob (optional JSON key): which grid candidates survive when a cell has more than
  // storedDisparities. "smallest" (the default, docs/ALGORITHM.md) or "votes".
  std::string gridKeep = "smallest";
  // Measurement-only knob (optional JSON key): "none" (default: MIDDLEBURY's add_corners is dropped) or
  // "nearest" (libelas's corner points added to the grids).
  std::string gridCorners = "none";

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

// Loads a generator configuration: a name resolves to <dir>/<name>.json (dir = $IELAS_CONFIG_DIR, else ../configs
// next to the executable, else the source tree's golden/configs); a path ending in .json is read directly.
// Throws std::runtime_error with a one-line message on an unknown name, a malformed file or an illegal value.
Config loadConfig(const std::string& nameOrFile);

// The --preset configuration: the named configurations' hardware parameters (windowSize 5, storedDisparities 20,
// candidateStep 5, gridSize 20, fill r7), libelas's values for `parameterSet` ("robotics" | "middlebury"),
// maximum size = the given frame size, and a prior table computed here.
Config presetConfig(const std::string& parameterSet, int dispMax, int width, int height);

// P[delta] = trunc((ln gamma - ln(gamma + exp(-delta^2 / (2 sigma^2)))) / beta), delta = 0..dispMax
// (docs/ALGORITHM.md, Configurations and frames).
std::vector<int> computePriorTable(int dispMax, double gamma, double sigma, double beta);

// Throws std::runtime_error naming the first illegal parameter (the same ranges as ElasParams).
void validateConfig(const Config& cfg);

// Recomputes the values derived from the card parameters (lattice/grid maxima, margins); keeps priorTable.
void deriveConfig(Config& cfg);

}  // namespace ielas
