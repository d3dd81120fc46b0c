// 3D model files into Meshes (sim/model_io.h) and their training views
// (sim/training_views.h): a textured OBJ and a vertex-coloured PLY written by the sim
// render like the mesh they came from; hostile files are refused by name.
#include "sim/model_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>

#include "sim/mesh.h"
#include "sim/objects.h"
#include "sim/training_views.h"
#include "tests/common/images.h"

namespace skimap::sim {
namespace {

namespace fs = std::filesystem;

class ModelIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // A folder per test: ctest runs the tests of this fixture side by side.
    dir_ = fs::path(::testing::TempDir()) /
           (std::string("model_io_test_") +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    absl::StatusOr<std::vector<Texture>> textures = LoadTextures(kDefaultTextureDir, 256, 2);
    ASSERT_TRUE(textures.ok()) << textures.status();
    box_ = MakePrintedBox({0.12f, 0.08f, 0.20f}, (*textures)[0]);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  void Write(const std::string& name, const std::string& bytes) const {
    std::ofstream(Path(name), std::ios::binary) << bytes;
  }
  // Mean absolute difference of two renders' colours where both show the model.
  static double ColourDifference(const TrainingView& a, const TrainingView& b) {
    cv::Mat both = a.mask & b.mask, diff;
    cv::absdiff(a.bgr, b.bgr, diff);
    const cv::Scalar mean = cv::mean(diff, both);
    return (mean[0] + mean[1] + mean[2]) / 3;
  }

  fs::path dir_;
  Mesh box_;
};

const dataset::Intrinsics kKinect{525, 525, 319.5, 239.5, 640, 480};
// Perfect renders: one fixed light, nothing behind the model, no sensor noise.
const TrainingViewOptions kPlain{.clutter = false, .lighting = false, .sensor = false};

TEST_F(ModelIoTest, ATexturedObjRendersLikeItsMesh) {
  ASSERT_TRUE(WriteObj(box_, Path("box.obj")).ok());
  absl::StatusOr<Mesh> loaded = LoadModel(Path("box.obj"));
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->triangles.size(), box_.triangles.size());
  EXPECT_TRUE(loaded->Bounds().isApprox(box_.Bounds(), 1e-4f));  // metres kept (auto)
  TrainingViewOptions few = kPlain;
  few.elevations_deg = {20};
  few.azimuths = 4;
  const std::vector<TrainingView> original = RenderTrainingViews(box_, kKinect, few);
  const std::vector<TrainingView> read = RenderTrainingViews(*loaded, kKinect, few);
  ASSERT_EQ(original.size(), 4u);
  ASSERT_EQ(read.size(), 4u);
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_LT(ColourDifference(original[i], read[i]), 3.0) << "view " << i;
    EXPECT_GT(cv::countNonZero(read[i].mask), 2000) << "view " << i;
  }
}

TEST_F(ModelIoTest, AVertexColouredPlyInMillimetresIsReadInMetres) {
  ASSERT_TRUE(WritePlyMm(box_, Path("box.ply")).ok());  // colours per face, millimetres
  absl::StatusOr<Mesh> loaded = LoadModel(Path("box.ply"));
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->triangles.size(), box_.triangles.size());
  EXPECT_TRUE(loaded->Bounds().isApprox(box_.Bounds(), 1e-3f));
  absl::StatusOr<Mesh> as_metres = LoadModel(Path("box.ply"), {.units = ModelUnits::kMetres});
  ASSERT_TRUE(as_metres.ok());
  EXPECT_NEAR(as_metres->Bounds().sizes().z(), 200.f, 0.01f);
  // Each face in the colour the PLY gives it: a render is all model-coloured, no black.
  TrainingViewOptions two = kPlain;
  two.elevations_deg = {35};
  two.azimuths = 2;
  const std::vector<TrainingView> views = RenderTrainingViews(*loaded, kKinect, two);
  ASSERT_EQ(views.size(), 2u);
  const cv::Scalar mean = cv::mean(views[0].bgr, views[0].mask);
  EXPECT_GT(mean[0] + mean[1] + mean[2], 30.0);
}

TEST_F(ModelIoTest, TrainingViewsOrbitTheModelWithItsPose) {
  const std::vector<TrainingView> views = RenderTrainingViews(box_, kKinect, kPlain);
  ASSERT_EQ(views.size(), 3u * 36u);  // elevations 10, 35, 60 x 36 azimuths
  const double distance = std::max(0.6f, 2.8f * box_.Diameter());  // the sim's orbits
  for (const TrainingView& v : views) {
    // The model's centre lies at the orbit's distance, projected near the image centre.
    const Eigen::Vector3d c = v.T_m2c * box_.Bounds().center().cast<double>();
    EXPECT_NEAR(c.norm(), distance, 0.01);
    EXPECT_NEAR(kKinect.fx * c.x() / c.z() + kKinect.cx, 319.5, 2.0);
    // Depth where the mask is, none elsewhere.
    EXPECT_EQ(cv::countNonZero(v.depth_mm > 0), cv::countNonZero(v.mask));
  }
}

// With every effect a view looks like a camera's: the model in front of a cluttered
// background, lit by a light of its own, with sensor noise; the mask and pose are the
// perfect render's. The default is clutter alone (chosen on validation renders).
TEST_F(ModelIoTest, ViewEffectsPutTheModelInACameraLikeScene) {
  const TrainingViewOptions defaults;
  EXPECT_TRUE(defaults.clutter);
  EXPECT_FALSE(defaults.lighting);
  EXPECT_FALSE(defaults.sensor);
  TrainingViewOptions few{.elevations_deg = {35}, .azimuths = 6, .lighting = true, .sensor = true};
  const std::vector<TrainingView> plain = [&] {
    TrainingViewOptions o = kPlain;
    o.elevations_deg = few.elevations_deg;
    o.azimuths = few.azimuths;
    return RenderTrainingViews(box_, kKinect, o);
  }();
  const std::vector<TrainingView> views = RenderTrainingViews(box_, kKinect, few);
  ASSERT_EQ(views.size(), 6u);
  ASSERT_EQ(plain.size(), 6u);
  std::vector<double> model_brightness;
  for (size_t i = 0; i < views.size(); ++i) {
    const TrainingView& v = views[i];
    EXPECT_EQ(cv::countNonZero(v.mask != plain[i].mask), 0) << "view " << i;
    EXPECT_TRUE(v.T_m2c.isApprox(plain[i].T_m2c)) << "view " << i;
    // Behind the model: a varied scene, not black.
    cv::Scalar mean, stddev;
    cv::meanStdDev(v.bgr, mean, stddev, ~v.mask);
    EXPECT_GT(mean[0] + mean[1] + mean[2], 60.0) << "view " << i;
    EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 40.0) << "view " << i;
    // Depth only on the model, most of it kept, and noisy: not the perfect render's.
    const int on_model = cv::countNonZero(v.mask);
    EXPECT_EQ(cv::countNonZero((v.depth_mm > 0) & ~v.mask), 0) << "view " << i;
    EXPECT_GT(cv::countNonZero(v.depth_mm > 0), on_model * 8 / 10) << "view " << i;
    EXPECT_GT(cv::norm(v.depth_mm, plain[i].depth_mm, cv::NORM_L1, v.depth_mm > 0), on_model)
        << "view " << i;
    const cv::Scalar m = cv::mean(v.bgr, v.mask);
    model_brightness.push_back(m[0] + m[1] + m[2]);
  }
  // Each view has its own light.
  const auto [lo, hi] = std::minmax_element(model_brightness.begin(), model_brightness.end());
  EXPECT_GT(*hi - *lo, 15.0);
  // Reproducible from the seed; another seed, another scene.
  const std::vector<TrainingView> again = RenderTrainingViews(box_, kKinect, few);
  EXPECT_EQ(cv::norm(again[0].bgr, views[0].bgr, cv::NORM_L1), 0.0);
  few.seed = 2;
  const std::vector<TrainingView> other = RenderTrainingViews(box_, kKinect, few);
  EXPECT_GT(cv::norm(other[0].bgr, views[0].bgr, cv::NORM_L1, ~views[0].mask),
            50.0 * cv::countNonZero(~views[0].mask));
  if (const char* dump = std::getenv("SKIMAP_DUMP_VIEWS")) {  // to look at them
    for (size_t i = 0; i < views.size(); ++i) {
      skimap::testing::ImWrite(std::string(dump) + "/view" + std::to_string(i) + ".png",
                               views[i].bgr);
    }
  }
}

TEST_F(ModelIoTest, HostileFilesAreRefusedByName) {
  Write("empty.ply", "");
  Write("header.ply", "ply\nformat ascii 1.0\nelement vertex\n");  // Assimp 5.2 loops on it
  Write("claims.ply",
        "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\nproperty float x\n"
        "end_header\n1234");
  Write("points.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n");
  Write("garbage.obj", std::string(4096, '\x9c'));
  Write("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  // A format outside the four read (an ASCII STL Assimp could read), by extension.
  Write("box.stl",
        "solid b\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
        "vertex 0 1 0\nendloop\nendfacet\nendsolid b\n");
  // Assimp 5.2 aborts on this one (found by tests/fuzz/model_file_fuzz.cc): its reader's
  // process dies, not this one.
  Write("abort.ply",
        std::string(
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty "
            "float y\nproperty float z\nproperty uchar red\nproperty int8r green\nproperty uchar "
            "blue\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n") +
            std::string(
                "\x00\x00\x00\x00\x00\x00\x00\x00\x06\x00\x00\x00\x0a\x14\x1e\xcd\xcc\xcc\x3d\x00"
                "\x00\x00\x00\x00\x00\x00\x00\x28\x32\x3c\x00\x00\x00\x00\xcd\xcc\xcc\x3d\x00\x00"
                "\x00\x00\x46\x50\x5a\x03\x00\x00\x00\x00\x01\x00\x00\x00\x02\x00\x00\x00",
                58));
  for (const char* name : {"empty.ply", "header.ply", "claims.ply", "points.ply", "garbage.obj",
                           "nan.obj", "box.stl", "abort.ply"}) {
    absl::StatusOr<Mesh> m = LoadModel(Path(name));
    EXPECT_EQ(m.status().code(), absl::StatusCode::kInvalidArgument) << name << ": " << m.status();
    EXPECT_NE(m.status().message().find(name), std::string::npos) << m.status();
  }
  EXPECT_EQ(LoadModel(Path("missing.obj")).status().code(), absl::StatusCode::kNotFound);
  ASSERT_TRUE(WriteObj(box_, Path("box.obj")).ok());
  EXPECT_EQ(LoadModel(Path("box.obj"), {.max_file_bytes = 100}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(LoadModel(Path("box.obj"), {.max_triangles = 4}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(ParseModelUnits("km", "--model_units").ok());
}

// A material's texture is read only from the model's folder: one that names a file outside
// it leaves the material's own colour.
TEST_F(ModelIoTest, ATextureOutsideTheModelsFolderIsNotRead) {
  fs::create_directories(dir_ / "model");
  ASSERT_TRUE(
      skimap::testing::ImWrite(Path("outside.png"), cv::Mat(8, 8, CV_8UC3, cv::Scalar(0, 0, 255))));
  Write("model/m.mtl", "newmtl a\nKd 0 1 0\nmap_Kd ../outside.png\n");
  Write("model/m.obj",
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\n"
        "f 1/1 2/2 3/3\n");
  absl::StatusOr<Mesh> m = LoadModel(Path("model/m.obj"));
  ASSERT_TRUE(m.ok()) << m.status();
  ASSERT_EQ(m->textures.size(), 1u);
  EXPECT_EQ(m->textures[0]->total(), 1u);  // the material's colour, not the 8x8 picture
  EXPECT_EQ(m->textures[0]->at<cv::Vec3b>(0, 0), cv::Vec3b(0, 255, 0));
  // Nor an MTL outside it: the material keeps Assimp's default (white), not the red it gives.
  Write("outside.mtl", "newmtl b\nKd 1 0 0\n");
  Write("model/n.obj", "mtllib ../outside.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl b\nf 1 2 3\n");
  absl::StatusOr<Mesh> n = LoadModel(Path("model/n.obj"));
  ASSERT_TRUE(n.ok()) << n.status();
  ASSERT_EQ(n->textures.size(), 1u);
  EXPECT_NE(n->textures[0]->at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255));
}

}  // namespace
}  // namespace skimap::sim
