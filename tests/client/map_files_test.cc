// The files written by the client follow their specs, read back by independent parsers
// written here (ROS map_server YAML + PGM; height map PNG + sidecar; PLY header).
#include "client/map_files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "tests/common/images.h"
#include "tests/common/test_temp_dir.h"

namespace skimap::client {
namespace {

std::string TempPath(const std::string& name) {
  return skimap::testing::TestTempDir("skimap_client_test") + "/" + name;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Flat "key: value" YAML, as map_server reads it.
std::map<std::string, std::string> ParseYaml(const std::string& text) {
  std::map<std::string, std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string value = line.substr(colon + 1);
    value.erase(0, value.find_first_not_of(' '));
    out[line.substr(0, colon)] = value;
  }
  return out;
}

struct Pgm {
  int width = 0, height = 0, maxval = 0;
  std::string pixels;
};

// Binary PGM (P5) with comments, per the netpbm spec.
Pgm ParsePgm(const std::string& bytes) {
  Pgm pgm;
  size_t pos = 0;
  auto token = [&]() {
    for (;;) {
      while (pos < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
      if (pos < bytes.size() && bytes[pos] == '#') {
        while (pos < bytes.size() && bytes[pos] != '\n') ++pos;
        continue;
      }
      break;
    }
    const size_t start = pos;
    while (pos < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[pos]))) ++pos;
    return bytes.substr(start, pos - start);
  };
  if (token() != "P5") return pgm;
  pgm.width = std::stoi(token());
  pgm.height = std::stoi(token());
  pgm.maxval = std::stoi(token());
  pgm.pixels = bytes.substr(pos + 1);  // exactly one whitespace after maxval
  return pgm;
}

TEST(MapFilesTest, RosMapIsTrinaryPgmWithTopRowAtMaxY) {
  v1::OccupancyGrid grid;
  grid.set_resolution(0.05);
  grid.set_width(3);
  grid.set_height(2);
  grid.set_origin_x(-1.5);
  grid.set_origin_y(2.25);
  // Row y=0: occupied, free, unknown; row y=1: free, free, occupied.
  const int8_t cells[6] = {100, 0, -1, 0, 0, 100};
  grid.set_data(reinterpret_cast<const char*>(cells), 6);
  const std::string yaml_path = TempPath("grid.yaml");
  ASSERT_TRUE(WriteRosMap(grid, yaml_path).ok());

  std::map<std::string, std::string> yaml = ParseYaml(Slurp(yaml_path));
  EXPECT_EQ(yaml["image"], "grid.pgm");
  EXPECT_DOUBLE_EQ(std::stod(yaml["resolution"]), 0.05);
  EXPECT_EQ(yaml["origin"], "[-1.5, 2.25, 0.0]");
  EXPECT_EQ(yaml["negate"], "0");
  EXPECT_EQ(yaml["mode"], "trinary");
  EXPECT_DOUBLE_EQ(std::stod(yaml["occupied_thresh"]), 0.65);
  EXPECT_DOUBLE_EQ(std::stod(yaml["free_thresh"]), 0.196);

  Pgm pgm = ParsePgm(Slurp(TempPath("grid.pgm")));
  ASSERT_EQ(pgm.width, 3);
  ASSERT_EQ(pgm.height, 2);
  EXPECT_EQ(pgm.maxval, 255);
  ASSERT_EQ(pgm.pixels.size(), 6u);
  const std::string expected = {char(254), char(254), char(0),     // image row 0 = y row 1
                                char(0),   char(254), char(205)};  // image row 1 = y row 0
  EXPECT_EQ(pgm.pixels, expected);
  // map_server's trinary reading: p = (255 - v) / 255; occupied > 0.65, free < 0.196.
  for (size_t i = 0; i < 6; ++i) {
    const double p = (255.0 - static_cast<uint8_t>(pgm.pixels[i])) / 255.0;
    const int row = 1 - int(i / 3), col = int(i % 3);
    const int8_t cell = cells[row * 3 + col];
    const int8_t read = p > 0.65 ? 100 : p < 0.196 ? 0 : -1;
    EXPECT_EQ(read, cell) << "pixel " << i;
  }
}

// A cost grid (inflation_radius > 0) is written for map_server's raw mode: each byte is
// the cell's value, which map_server puts into the int8 data as it is (255 reads -1).
TEST(MapFilesTest, CostGridIsRawPgm) {
  v1::OccupancyGrid grid;
  grid.set_resolution(0.05);
  grid.set_width(3);
  grid.set_height(1);
  grid.set_inflation_radius(0.3);
  const int8_t cells[3] = {100, 42, -1};
  grid.set_data(reinterpret_cast<const char*>(cells), 3);
  const std::string yaml_path = TempPath("costs.yaml");
  ASSERT_TRUE(WriteRosMap(grid, yaml_path).ok());
  std::map<std::string, std::string> yaml = ParseYaml(Slurp(yaml_path));
  EXPECT_EQ(yaml["mode"], "raw");
  Pgm pgm = ParsePgm(Slurp(TempPath("costs.pgm")));
  ASSERT_EQ(pgm.pixels.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(int8_t(pgm.pixels[i]), cells[i]) << i;
}

TEST(MapFilesTest, HeightMapPngStoresMillimetresAboveOffsetAndZeroForUnknown) {
  v1::HeightMap map;
  map.set_resolution(0.1);
  map.set_width(2);
  map.set_height(1);
  map.set_origin_x(1);
  map.set_origin_y(2);
  map.add_heights(0.25f);
  map.add_heights(std::nanf(""));
  const std::string path = TempPath("height.png");
  ASSERT_TRUE(WriteHeightMap(map, path).ok());
  cv::Mat image = skimap::testing::ImRead(path, skimap::testing::ImageMode::kUnchanged);
  ASSERT_EQ(image.type(), CV_16UC1);
  std::map<std::string, std::string> yaml = ParseYaml(Slurp(TempPath("height.yaml")));
  const double offset = std::stod(yaml["z_offset"]), scale = std::stod(yaml["z_scale"]);
  EXPECT_EQ(yaml["origin"], "[1, 2]");
  EXPECT_NEAR(offset + image.at<uint16_t>(0, 0) * scale, 0.25, 0.0011);
  EXPECT_EQ(image.at<uint16_t>(0, 1), 0);
}

TEST(MapFilesTest, PlyHeaderCountsVoxels) {
  std::vector<v1::Voxel> voxels(3);
  voxels[1].set_rgb(0xff8000);
  const std::string path = TempPath("voxels.ply");
  ASSERT_TRUE(WritePly(voxels, path).ok());
  const std::string bytes = Slurp(path);
  const size_t end = bytes.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(bytes.find("element vertex 3\n"), std::string::npos);
  EXPECT_EQ(bytes.size() - (end + 11), 3u * (3 * 4 + 3 + 4));
  EXPECT_EQ(static_cast<uint8_t>(bytes[end + 11 + 19 + 12]), 0xff);  // voxel 1 red
}

}  // namespace
}  // namespace skimap::client
