// dataset/model_points.h: PLY models (ASCII as skimap-sim writes them, binary as BOP
// distributes them) read as points in metres; errors name the file.
#include "dataset/model_points.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>

namespace skimap::dataset {
namespace {

namespace fs = std::filesystem;

class ModelPointsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("model_points_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

// One triangle, millimetres: (0,0,0), (100,0,0), (0,50,20).
constexpr float kVertices[3][3] = {{0, 0, 0}, {100, 0, 0}, {0, 50, 20}};

void ExpectTriangleInMetres(const std::vector<Eigen::Vector3d>& points) {
  ASSERT_EQ(points.size(), 3u);
  for (int v = 0; v < 3; ++v) {
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(points[v][a], kVertices[v][a] / 1000.0, 1e-7);
  }
}

TEST_F(ModelPointsTest, ReadsAnAsciiPlyWithColoursInMetres) {
  std::ofstream out(Path("ascii.ply"));
  out << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : kVertices) out << v[0] << " " << v[1] << " " << v[2] << " 255 0 0\n";
  out << "3 0 1 2\n";
  out.close();
  absl::StatusOr<std::vector<Eigen::Vector3d>> points = LoadModelPoints(Path("ascii.ply"));
  ASSERT_TRUE(points.ok()) << points.status();
  ExpectTriangleInMetres(*points);
}

TEST_F(ModelPointsTest, ReadsABinaryPly) {
  std::ofstream out(Path("binary.ply"), std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
         "property float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n";
  out.write(reinterpret_cast<const char*>(kVertices), sizeof(kVertices));
  const uint8_t n = 3;
  const int32_t face[3] = {0, 1, 2};
  out.write(reinterpret_cast<const char*>(&n), 1);
  out.write(reinterpret_cast<const char*>(face), sizeof(face));
  out.close();
  absl::StatusOr<std::vector<Eigen::Vector3d>> points = LoadModelPoints(Path("binary.ply"));
  ASSERT_TRUE(points.ok()) << points.status();
  ExpectTriangleInMetres(*points);
}

TEST_F(ModelPointsTest, KeepsAnEvenSubsetOfALargeModel) {
  std::ofstream out(Path("cloud.ply"));
  out << "ply\nformat ascii 1.0\nelement vertex 1000\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n";
  for (int i = 0; i < 1000; ++i) out << i << " 0 0\n";
  out.close();
  absl::StatusOr<std::vector<Eigen::Vector3d>> all = LoadModelPoints(Path("cloud.ply"), 1.0);
  ASSERT_TRUE(all.ok()) << all.status();
  EXPECT_EQ(all->size(), 1000u);
  absl::StatusOr<std::vector<Eigen::Vector3d>> some = LoadModelPoints(Path("cloud.ply"), 1.0, 100);
  ASSERT_TRUE(some.ok()) << some.status();
  ASSERT_EQ(some->size(), 100u);
  for (size_t i = 0; i < some->size(); ++i) EXPECT_EQ((*some)[i].x(), 10.0 * i);
}

TEST_F(ModelPointsTest, ErrorsNameTheFile) {
  absl::StatusOr<std::vector<Eigen::Vector3d>> missing = LoadModelPoints(Path("none.ply"));
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("none.ply"), std::string::npos);
  // Each refused with the file named, none hanging (Assimp alone loops forever on the
  // first) or crashing.
  const std::vector<std::string> bad = {
      "ply\nformat ascii 1.0\nelement vertex nonsense\n",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n",  // no end_header
      "ply\nelement vertex 1\nproperty float x\nend_header\n1\n",     // no format
      "not a model at all",
      "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\nproperty float x\n"
      "property float y\nproperty float z\nend_header\nabc"};  // claims more than it holds
  for (size_t i = 0; i < bad.size(); ++i) {
    const std::string path = Path("bad" + std::to_string(i) + ".ply");
    std::ofstream(path) << bad[i];
    absl::StatusOr<std::vector<Eigen::Vector3d>> garbage = LoadModelPoints(path);
    EXPECT_EQ(garbage.status().code(), absl::StatusCode::kInvalidArgument) << bad[i];
    EXPECT_NE(garbage.status().message().find(path), std::string::npos) << garbage.status();
  }
}

}  // namespace
}  // namespace skimap::dataset
