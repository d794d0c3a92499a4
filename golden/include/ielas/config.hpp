// The generator configuration, read from golden/configs/<name>.json (written by the Scala ElasParams).
// Field names are the JSON keys. Nothing here is typed twice: the JSON is the only source.
#pragma once
#include <string>
#include <vector>

namespace ielas {

// One legality rule of a card parameter, as the configuration JSON's "legal" object states it (ElasParams.legal):
// kind "range" [lo, hi], "aboveUpTo" (lo, hi], "oneOf" [v, ...] or "zeroOrPowerOfTwo" [lo, hi]. A bound is a number or
// a string: "NAME", "NAME+K", "NAME-K" (an integer card parameter plus K) or "(2*NAME+1)^2".
struct LegalArg {
  bool isString = false;
  std::string text;
  double number = 0.0;
};
struct LegalRule {
  std::string param, kind;
  std::vector<LegalArg> args;
};

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
  // Implementation knobs of the hardware: read and checked, not used by the golden model (its results do not
  // depend on the lane counts or the input rate).
  int cyclesPerPixel = 1, supportLanes = 0, denseLanes = 0;
  // derived by ElasParams (recomputed by presetConfig and overrideConfig)
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
  std::vector<LegalRule> legal;  // the JSON's "legal" object, in its order
  std::vector<std::string> presetFollows;  // preset files: parameters moved into their legal range after the size
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

// The --preset configuration: the preset file <configs>/presets/<parameterSet>.json (written by ElasParams: the
// named configurations' hardware parameters and the parameter set's values) with maximum size = the given frame size
// and dispMax, the parameters it lists in "presetFollows" moved into their legal range, the derived values and the
// prior table recomputed, and every rule of its "legal" object checked.
Config presetConfig(const std::string& parameterSet, int dispMax, int width, int height);

// The path of the preset file of `parameterSet`; throws "unknown preset" naming the legal ones.
std::string presetFile(const std::string& parameterSet);

// Sets the card parameter `key` (a field of ElasParams but the name) from `value`, then recomputes the derived values
// and the prior table and checks every rule. Throws a one-line message on an unknown key or an illegal value
// (cfg is then unchanged).
void overrideConfig(Config& cfg, const std::string& key, const std::string& value);

// The configuration's parameters and derived values as one JSON object (the keys of the configuration JSON but
// "legal"), for `ielas-golden config --print`.
std::string configToJson(const Config& cfg);

// P[delta] = trunc((ln gamma - ln(gamma + exp(-delta^2 / (2 sigma^2)))) / beta), delta = 0..dispMax
// (docs/ALGORITHM.md, Configurations and frames).
std::vector<int> computePriorTable(int dispMax, double gamma, double sigma, double beta);

// Throws std::runtime_error naming the first illegal parameter: the rules of cfg.legal (the JSON's, so the same as
// ElasParams's), then the structural checks (prior table length, the golden-only knobs).
void validateConfig(const Config& cfg);

// Recomputes the sizes derived from the card parameters (lattice/grid maxima, margins); keeps priorTable.
void deriveConfig(Config& cfg);

}  // namespace ielas
