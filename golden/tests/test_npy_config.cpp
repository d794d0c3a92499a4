// npy round trip and header bytes; configuration loading, the preset configuration and the prior table.
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "check.hpp"
#include "ielas/config.hpp"
#include "ielas/npy.hpp"

using namespace ielas;

namespace {

std::string tmpDir() {
  std::string d = IELAS_TEST_TMP_DIR;
  mkdir(d.c_str(), 0777);
  return d;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void testNpyHeader() {
  // Hand-written expected header for a (2, 3) <i2 array: numpy pads to a multiple of 64 bytes with spaces + '\n'.
  const std::string dict = "{'descr': '<i2', 'fortran_order': False, 'shape': (2, 3), }";
  std::string expected("\x93NUMPY\x01\x00", 8);
  const size_t headerLen = 128 - 10;  // the 59-byte dict + '\n' does not fit in 64 - 10, so 128 - 10
  expected.push_back(static_cast<char>(headerLen));
  expected.push_back('\0');
  expected += dict + std::string(headerLen - dict.size() - 1, ' ') + "\n";
  CHECK(npyHeader("<i2", {2, 3}) == expected);
  CHECK_EQ(npyHeader("|u1", {376, 1242, 16}).size() % 64, 0u);
  CHECK_THROWS(npyHeader("<f4", {2, 2}), "unsupported npy dtype");

  const std::string path = tmpDir() + "/header.npy";
  const int16_t values[6] = {-1, 0, 1, 255, -32768, 32767};
  writeNpy(path, "<i2", {2, 3}, values);
  std::string bytes = readAll(path);
  CHECK_EQ(bytes.size(), 128u + 12u);
  CHECK(bytes.substr(0, 128) == expected);
  // Little-endian element bytes: -1 = ff ff, 255 = ff 00, -32768 = 00 80.
  CHECK_EQ(static_cast<unsigned char>(bytes[128]), 0xff);
  CHECK_EQ(static_cast<unsigned char>(bytes[129]), 0xff);
  CHECK_EQ(static_cast<unsigned char>(bytes[134]), 0xff);
  CHECK_EQ(static_cast<unsigned char>(bytes[135]), 0x00);
  CHECK_EQ(static_cast<unsigned char>(bytes[136]), 0x00);
  CHECK_EQ(static_cast<unsigned char>(bytes[137]), 0x80);
}

void testNpyRoundTrip() {
  const std::string dir = tmpDir();
  {
    std::vector<int32_t> v = {-2147483647 - 1, -1, 0, 1, 2147483647, 42, 7, 8};
    writeNpy(dir + "/i4.npy", "<i4", {2, 2, 2}, v.data());
    NpyArray a = readNpy(dir + "/i4.npy");
    CHECK(a.descr == "<i4");
    CHECK(a.shape == std::vector<int>({2, 2, 2}));
    for (size_t i = 0; i < v.size(); ++i) CHECK_EQ(a.value(i), static_cast<int64_t>(v[i]));
  }
  {
    std::vector<uint16_t> v = {0, 1, 65535, 256, 4, 5};
    writeNpy(dir + "/u2.npy", "<u2", {1, 2, 3, 1}, v.data());
    NpyArray a = readNpy(dir + "/u2.npy");
    CHECK(a.shape == std::vector<int>({1, 2, 3, 1}));
    CHECK_EQ(a.value(2), 65535);
    CHECK_EQ(a.value(3), 256);
  }
  {
    cv::Mat m(3, 4, CV_8UC(16));
    for (size_t i = 0; i < m.total() * 16; ++i) m.data[i] = static_cast<uint8_t>(i * 7);
    writeNpyMat(dir + "/u1.npy", m);
    NpyArray a = readNpy(dir + "/u1.npy");
    CHECK(a.descr == "|u1");
    CHECK(a.shape == std::vector<int>({3, 4, 16}));
    CHECK_EQ(a.value(5 * 16 + 3), static_cast<uint8_t>((5 * 16 + 3) * 7));
  }
  {
    std::ofstream bad(dir + "/bad.npy", std::ios::binary);
    bad << "not numpy";
  }
  CHECK_THROWS(readNpy(dir + "/bad.npy"), "not an npy file");
}

void testConfigFile() {
  Config k = loadConfig("kitti");
  CHECK(k.name == "kitti");
  CHECK_EQ(k.maxWidth, 1242);
  CHECK_EQ(k.maxHeight, 376);
  CHECK_EQ(k.dispMax, 255);
  CHECK_EQ(k.windowSize, 5);
  CHECK_EQ(k.storedDisparities, 20);
  CHECK_EQ(k.candidateStep, 5);
  CHECK_EQ(k.gridSize, 20);
  CHECK(k.parameterSet == "robotics");
  CHECK(k.fillRule == "r7");
  CHECK_EQ(k.supportThresholdPercent, 85);
  CHECK_EQ(k.supportTexture, 10);
  CHECK_EQ(k.inconWindowSize, 5);
  CHECK_EQ(k.lrThreshold, 2);
  CHECK_EQ(k.latticeColsMax, 250);  // 0, 5, ..., 1240 = 249 nodes, plus 1241
  CHECK_EQ(k.latticeRowsMax, 76);   // 0, 5, ..., 375 = 76 nodes; 375 = H-1 is on the step
  CHECK_EQ(k.gridColsMax, 63);
  CHECK_EQ(k.gridRowsMax, 19);
  CHECK_EQ(k.priorTable.size(), 256u);
  const int robotics[4] = {-14, -9, -2, 0};
  for (int i = 0; i < 4; ++i) CHECK_EQ(k.priorTable[i], robotics[i]);
  for (size_t i = 4; i < k.priorTable.size(); ++i) CHECK_EQ(k.priorTable[i], 0);

  Config m = loadConfig("kitti-middlebury");
  const int middlebury[4] = {-9, -5, -1, 0};
  for (int i = 0; i < 4; ++i) CHECK_EQ(m.priorTable[i], middlebury[i]);
  CHECK_EQ(m.supportThresholdPercent, 95);
  CHECK(m.addCorners);
  CHECK_EQ(m.planeRadius, 3);

  Config byPath = loadConfig(std::string(IELAS_TEST_CONFIG_DIR) + "/small.json");
  CHECK_EQ(byPath.maxWidth, 128);
  CHECK_EQ(byPath.dispMax, 31);

  CHECK_THROWS(loadConfig("no-such-configuration"), "unknown configuration");
  const std::string dir = tmpDir();
  {
    std::ofstream bad(dir + "/broken.json");
    bad << "{ \"name\": \"broken\", \"maxWidth\": ";
  }
  CHECK_THROWS(loadConfig(dir + "/broken.json"), "malformed JSON");
  {
    std::ofstream partial(dir + "/partial.json");
    partial << "{ \"name\": \"partial\", \"maxWidth\": 64 }";
  }
  CHECK_THROWS(loadConfig(dir + "/partial.json"), "missing key");
}

void testPresetMatchesJson() {
  // presetConfig computes the prior table itself; it must equal ElasParams's table in the JSON.
  const std::pair<const char*, const char*> pairs[] = {{"robotics", "kitti"}, {"middlebury", "kitti-middlebury"}};
  for (const auto& p : pairs) {
    Config json = loadConfig(p.second);
    Config preset = presetConfig(p.first, 255, 1242, 376);
    CHECK(preset.priorTable == json.priorTable);
    CHECK_EQ(preset.supportThresholdPercent, json.supportThresholdPercent);
    CHECK_EQ(preset.gamma, json.gamma);
    CHECK_EQ(preset.planeRadius, json.planeRadius);
    CHECK_EQ(preset.matchTexture, json.matchTexture);
    CHECK_EQ(preset.addCorners, json.addCorners);
    CHECK_EQ(preset.ipolGapWidth, json.ipolGapWidth);
    CHECK_EQ(preset.filterMedian, json.filterMedian);
    CHECK_EQ(preset.filterAdaptiveMean, json.filterAdaptiveMean);
    CHECK_EQ(preset.postprocessOnlyLeft, json.postprocessOnlyLeft);
    CHECK_EQ(preset.latticeColsMax, json.latticeColsMax);
    CHECK_EQ(preset.gridRowsMax, json.gridRowsMax);
    CHECK_EQ(preset.fillC, json.fillC);
    CHECK(preset.fillRule == json.fillRule);
  }
  Config tsukuba = loadConfig("tsukuba");
  CHECK(presetConfig("robotics", 127, 640, 480).priorTable == tsukuba.priorTable);
  CHECK_EQ(presetConfig("robotics", 31, 128, 64).fillC, 31);
  CHECK_THROWS(presetConfig("indoor", 255, 640, 480), "unknown preset");
  // The ranges are the preset file's (ElasParams's): dispMax from 15, below the width; fillC and sDelta follow.
  CHECK_THROWS(presetConfig("robotics", 14, 640, 480), "dispMax = 14 is out of range (legal: 15..1023)");
  CHECK_THROWS(presetConfig("robotics", 63, 60, 40), "dispMax = 63 is out of range (legal: 15..59)");
  CHECK_EQ(presetConfig("robotics", 31, 48, 16).sDelta, 48);
  CHECK_EQ(presetConfig("robotics", 31, 48, 16).fillC, 31);
}

void testLegalFromJson() {
  // Every value is checked against the JSON's "legal" object; a file without it is refused.
  const std::string dir = tmpDir();
  std::ifstream in(std::string(IELAS_TEST_CONFIG_DIR) + "/small.json");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto write = [&](const std::string& name, const std::string& body) {
    std::ofstream(dir + "/" + name) << body;
    return dir + "/" + name;
  };
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    size_t at = t.find(from);
    CHECK(at != std::string::npos);
    if (at != std::string::npos) t.replace(at, from.size(), to);
    return t;
  };
  size_t legal = text.find(",\n  \"legal\"");
  CHECK(legal != std::string::npos);
  CHECK_THROWS(loadConfig(write("nolegal.json", text.substr(0, legal) + "\n}\n")), "missing key 'legal'");
  CHECK_THROWS(loadConfig(write("lr.json", replaced("\"lrThreshold\": 2,", "\"lrThreshold\": 32,"))),
               "lrThreshold = 32 is out of range (legal: 0..31)");
  CHECK_EQ(loadConfig(write("lr31.json", replaced("\"lrThreshold\": 2,", "\"lrThreshold\": 31,"))).lrThreshold, 31);
  CHECK_THROWS(loadConfig(write("norule.json", replaced("\"lrThreshold\": [[\"range\", 0, \"dispMax\"]],", ""))),
               "no legal entry for 'lrThreshold'");
  Config small = loadConfig("small");
  CHECK_THROWS(overrideConfig(small, "speckleWindowRows", "65"), "speckleWindowRows = 65 is out of range (legal: 1..64)");
  CHECK_THROWS(overrideConfig(small, "cyclesPerPixel", "3"), "cyclesPerPixel = 3 is not supported (legal: 1, 2, 4, 8)");
}

}  // namespace

int main() {
  testNpyHeader();
  testNpyRoundTrip();
  testConfigFile();
  testPresetMatchesJson();
  testLegalFromJson();
  return testExitCode("test_npy_config");
}
