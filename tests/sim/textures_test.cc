// LoadTextures (sim/objects.h): pictures as they are, and cut into tiles when a folder has
// fewer pictures than the scenes need.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>

#include "absl/strings/str_cat.h"
#include "opencv2/core.hpp"
#include "sim/objects.h"
#include "tests/common/images.h"

namespace skimap::sim {
namespace {

namespace fs = std::filesystem;

// A folder with colourful noise pictures of the given sizes (a.png, b.png, ...).
std::string PictureFolder(const std::string& name, const std::vector<cv::Size>& sizes) {
  const fs::path dir = fs::temp_directory_path() / absl::StrCat("skimap_textures_", name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::RNG rng(7);
  for (size_t i = 0; i < sizes.size(); ++i) {
    cv::Mat img(sizes[i], CV_8UC3);
    rng.fill(img, cv::RNG::UNIFORM, 0, 256);
    skimap::testing::ImWrite((dir / (std::string(1, static_cast<char>('a' + i)) + ".png")).string(),
                             img);
  }
  return dir.string();
}

bool SamePixels(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

TEST(TexturesTest, EnoughPicturesAreLoadedWhole) {
  const std::string dir = PictureFolder("whole", {{200, 120}, {100, 100}});
  absl::StatusOr<std::vector<Texture>> t = LoadTextures(dir, 256, 2);
  ASSERT_TRUE(t.ok()) << t.status();
  ASSERT_EQ(t->size(), 2u);
  EXPECT_EQ((*t)[0]->size(), cv::Size(200, 120));
  EXPECT_TRUE(SamePixels(*(*t)[0], skimap::testing::ImRead(dir + "/a.png")));
}

TEST(TexturesTest, TooFewPicturesAreCutIntoTilesInReadingOrder) {
  const std::string dir = PictureFolder("tiles", {{300, 300}, {300, 300}});
  absl::StatusOr<std::vector<Texture>> t = LoadTextures(dir, 256, 8);  // 2 x 2 x 2 tiles
  ASSERT_TRUE(t.ok()) << t.status();
  ASSERT_EQ(t->size(), 8u);
  const cv::Mat a = skimap::testing::ImRead(dir + "/a.png"),
                b = skimap::testing::ImRead(dir + "/b.png");
  EXPECT_TRUE(SamePixels(*(*t)[0], a(cv::Rect(0, 0, 150, 150))));
  EXPECT_TRUE(SamePixels(*(*t)[1], a(cv::Rect(150, 0, 150, 150))));
  EXPECT_TRUE(SamePixels(*(*t)[3], a(cv::Rect(150, 150, 150, 150))));
  EXPECT_TRUE(SamePixels(*(*t)[4], b(cv::Rect(0, 0, 150, 150))));
  // At most 4 x 4 tiles; tiles are scaled like pictures (longer side at most max_side).
  t = LoadTextures(dir, 64, 1000);
  ASSERT_TRUE(t.ok()) << t.status();
  ASSERT_EQ(t->size(), 32u);
  EXPECT_EQ((*t)[0]->size(), cv::Size(64, 64));
}

TEST(TexturesTest, APictureTooSmallToCutStaysWhole) {
  const std::string dir = PictureFolder("small", {{300, 300}, {100, 100}});
  absl::StatusOr<std::vector<Texture>> t = LoadTextures(dir, 256, 8);
  ASSERT_TRUE(t.ok()) << t.status();
  ASSERT_EQ(t->size(), 5u);  // 4 tiles of a, b whole (its tiles would be 50 px)
  EXPECT_TRUE(SamePixels(*(*t)[4], skimap::testing::ImRead(dir + "/b.png")));
}

// The default photographs are enough for a scene: they are never cut (the datasets made
// before tiling existed stay the same).
TEST(TexturesTest, TheDefaultPhotographsAreNotCut) {
  absl::StatusOr<std::vector<Texture>> whole = LoadTextures(kDefaultTextureDir);
  absl::StatusOr<std::vector<Texture>> scene =
      LoadTextures(kDefaultTextureDir, 256, kSceneTextures);
  ASSERT_TRUE(whole.ok() && scene.ok());
  EXPECT_GE(static_cast<int>(whole->size()), kSceneTextures);
  ASSERT_EQ(scene->size(), whole->size());
  for (size_t i = 0; i < whole->size(); ++i)
    EXPECT_TRUE(SamePixels(*(*whole)[i], *(*scene)[i])) << i;
}

}  // namespace
}  // namespace skimap::sim
