/// The 3DGS PLY reader and writer: round trip, SH degree adaptation, files from other tools
/// (properties in another order), and hostile or broken files (truncated, huge counts, repeated
/// properties), which must give a clear std::runtime_error and leave the map unchanged.
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/gaussian_ply.h"

namespace dypho::mapping {
namespace DYPHO_UNITY_ID {

std::string tempPath(const std::string& name) {
  return "/tmp/dypho_test_ply_" + std::to_string(::getpid()) + "_" + name;
}

/// A binary PLY with the given float properties (in that order) and rows.
void writePly(const std::string& path, const std::string& count, const std::vector<std::string>& props,
              const std::vector<std::vector<float>>& rows) {
  std::ofstream f(path, std::ios::binary);
  f << "ply\nformat binary_little_endian 1.0\nelement vertex " << count << "\n";
  for (const auto& p : props) f << "property float " << p << "\n";
  f << "end_header\n";
  for (const auto& r : rows)
    f.write(reinterpret_cast<const char*>(r.data()), static_cast<std::streamsize>(r.size() * sizeof(float)));
}

std::string loadError(const std::string& path, GaussianMap& map) {
  try {
    readGaussianPly(path, map);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(GaussianPly, RoundTripAndCorruptFiles) {
  GaussianMap map(2, 10);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (int i = 0; i < 5; ++i) {
    GaussianInit g;
    g.position_w = {u(rng), u(rng), u(rng)};
    g.log_scale = {u(rng), u(rng), u(rng)};
    g.rotation_wxyz = {1.f, u(rng), u(rng), u(rng)};
    g.opacity_logit = u(rng);
    for (int k = 0; k < 27; ++k) g.sh.push_back(u(rng));
    map.add(g);
  }
  const std::string path = tempPath("map.ply");
  {
    std::ofstream f(path, std::ios::binary);
    writeGaussianPly(f, map);
  }
  GaussianMap back(2, 10);
  EXPECT_EQ(readGaussianPly(path, back), 5u);
  for (int p = 0; p < kNumGaussianParams; ++p)
    for (std::size_t i = 0; i < map.size() * map.width(p); ++i)
      ASSERT_EQ(map.data(p)[i], back.data(p)[i]) << p;  // bit-exact
  // Degree 2 file into a degree-1 map: DC and first-order coefficients kept.
  GaussianMap low(1, 3);
  std::string note;
  EXPECT_EQ(readGaussianPly(path, low, &note), 3u);  // capacity 3: the rest dropped
  EXPECT_NE(note.find("capacity"), std::string::npos) << note;
  for (int k = 0; k < 12; ++k) EXPECT_EQ(low.data(kParamSh)[k], map.data(kParamSh)[k]);
  // Truncated payload.
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string cut = tempPath("cut.ply");
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 10);
  GaussianMap keep(2, 10);
  keep.add(GaussianInit());
  try {
    readGaussianPly(cut, keep);
    FAIL() << "truncated file accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  EXPECT_EQ(keep.size(), 1u);  // unchanged on error
  // ASCII, garbage, missing property, missing file.
  const std::string ascii = tempPath("ascii.ply");
  std::ofstream(ascii) << "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  EXPECT_THROW(readGaussianPly(ascii, keep), std::runtime_error);
  std::ofstream(ascii) << "not a ply\n";
  EXPECT_THROW(readGaussianPly(ascii, keep), std::runtime_error);
  std::ofstream(ascii) << "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nend_header\n";
  EXPECT_THROW(readGaussianPly(ascii, keep), std::runtime_error);
  EXPECT_THROW(readGaussianPly(tempPath("missing.ply"), keep), std::runtime_error);
  std::remove(path.c_str());
  std::remove(cut.c_str());
  std::remove(ascii.c_str());
}

// Other tools write the same properties in other orders, with extras between them. Every value
// must come from the column its name says. (A reader that assumed x, y, z adjacent read past the
// row when 'x' came last: found by fuzz_gaussian_ply.)
TEST(GaussianPly, PropertiesAreFoundByNameInAnyOrder) {
  const std::vector<std::string> props = {"rot_3",  "opacity", "scale_2", "f_dc_2",  "red",    "rot_0", "y", "scale_0",
                                          "f_dc_0", "z",       "rot_2",   "scale_1", "f_dc_1", "rot_1", "x"};
  std::vector<float> row(props.size());
  for (std::size_t i = 0; i < row.size(); ++i) row[i] = 0.25f * static_cast<float>(i + 1);
  auto value = [&](const std::string& n) {
    for (std::size_t i = 0; i < props.size(); ++i)
      if (props[i] == n) return row[i];
    return -1.f;
  };
  const std::string path = tempPath("shuffled.ply");
  writePly(path, "1", props, {row});
  GaussianMap map(0, 4);
  ASSERT_EQ(readGaussianPly(path, map), 1u);
  const float* pos = map.data(kParamPosition);
  EXPECT_EQ(pos[0], value("x"));
  EXPECT_EQ(pos[1], value("y"));
  EXPECT_EQ(pos[2], value("z"));
  for (int j = 0; j < 3; ++j) EXPECT_EQ(map.data(kParamLogScale)[j], value("scale_" + std::to_string(j))) << j;
  for (int j = 0; j < 4; ++j) EXPECT_EQ(map.data(kParamRotation)[j], value("rot_" + std::to_string(j))) << j;
  for (int j = 0; j < 3; ++j) EXPECT_EQ(map.data(kParamSh)[j], value("f_dc_" + std::to_string(j))) << j;
  EXPECT_EQ(map.data(kParamOpacity)[0], value("opacity"));
  std::remove(path.c_str());
}

TEST(GaussianPly, HostileHeadersAreRefusedWithoutAllocating) {
  const std::vector<std::string> props = {"x",       "y",       "z",       "f_dc_0", "f_dc_1", "f_dc_2", "opacity",
                                          "scale_0", "scale_1", "scale_2", "rot_0",  "rot_1",  "rot_2",  "rot_3"};
  const std::vector<float> row(props.size(), 0.5f);
  GaussianMap keep(0, 4);
  keep.add(GaussianInit());
  const std::string path = tempPath("hostile.ply");
  // Counts whose byte size overflows 64 bits (or would need exabytes): refused as truncated.
  for (const std::string count : {"2", "4611686018427387904", "1317624576693539402", "9223372036854775807"}) {
    writePly(path, count, props, {row});
    const std::string what = loadError(path, keep);
    EXPECT_NE(what.find("truncated"), std::string::npos) << count << ": " << what;
    EXPECT_EQ(keep.size(), 1u) << count;
  }
  // The same property twice: which column is meant is unknowable.
  std::vector<std::string> twice = props;
  twice.push_back("x");
  writePly(path, "1", twice, {std::vector<float>(twice.size(), 0.5f)});
  EXPECT_NE(loadError(path, keep).find("'x' is declared twice"), std::string::npos) << loadError(path, keep);
  // A non-number count.
  writePly(path, "many", props, {row});
  EXPECT_NE(loadError(path, keep).find("bad vertex count"), std::string::npos) << loadError(path, keep);
  EXPECT_EQ(keep.size(), 1u);
  std::remove(path.c_str());
}

}  // namespace DYPHO_UNITY_ID
}  // namespace dypho::mapping
