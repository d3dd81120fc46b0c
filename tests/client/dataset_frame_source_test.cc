// DatasetFrameSource (client/cli/dataset_frame_source.h): frames prepared ahead on worker
// threads come out in the dataset's order, a frame with a missing file is that frame's
// error and the source goes on, every / max_frames select the frames, and a source
// dropped before its end stops its workers.
#include "client/cli/dataset_frame_source.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dataset/reader.h"
#include "tests/common/images.h"

namespace skimap::client {
namespace {

namespace fs = std::filesystem;

// A TUM sequence folder of `count` frames one second apart; frame i's depth pixels are all
// i + 1 (8 x 6, 16-bit PNG), its pose is at x = i metres.
class TumFolder {
 public:
  TumFolder(const std::string& name, int count)
      : dir_(fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    fs::create_directories(dir_ / "rgb");
    fs::create_directories(dir_ / "depth");
    std::ofstream rgb(dir_ / "rgb.txt"), depth(dir_ / "depth.txt"), poses(dir_ / "groundtruth.txt");
    for (int i = 0; i < count; ++i) {
      const std::string file = std::to_string(i) + ".png";
      skimap::testing::ImWrite((dir_ / "rgb" / file).string(),
                               cv::Mat(6, 8, CV_8UC3, cv::Scalar(i, i, i)));
      skimap::testing::ImWrite((dir_ / "depth" / file).string(),
                               cv::Mat(6, 8, CV_16UC1, cv::Scalar(i + 1)));
      rgb << i << ".0 rgb/" << file << "\n";
      depth << i << ".0 depth/" << file << "\n";
      poses << i << ".0 " << i << " 0 0 0 0 0 1\n";
    }
  }
  ~TumFolder() { fs::remove_all(dir_); }

  std::string path() const { return dir_.string(); }
  std::vector<dataset::Frame> Frames() const {
    absl::StatusOr<dataset::Sequence> sequence = dataset::LoadSequence(path());
    EXPECT_TRUE(sequence.ok()) << sequence.status();
    return sequence.ok() ? sequence->frames : std::vector<dataset::Frame>();
  }

 private:
  fs::path dir_;
};

// The first depth pixel of a RAW_U16 frame (little-endian).
int FirstDepth(const v1::Frame& frame) {
  return static_cast<uint8_t>(frame.depth()[0]) | static_cast<uint8_t>(frame.depth()[1]) << 8;
}

// Every item the source yields until its end.
std::vector<FrameOrError> Drain(FrameSource& source) {
  std::vector<FrameOrError> items;
  while (true) {
    absl::StatusOr<std::optional<FrameOrError>> next = source.Next();
    EXPECT_TRUE(next.ok()) << next.status();
    if (!next.ok() || !next->has_value()) break;
    items.push_back(**std::move(next));
  }
  return items;
}

TEST(DatasetFrameSourceTest, YieldsFramesInOrderWhilePreparingAhead) {
  const TumFolder folder("frame_source_order", 24);
  DatasetFrameSource::Options options;
  options.depth_encoding = v1::DEPTH_ENCODING_RAW_U16;
  options.threads = 3;
  options.read_ahead = 4;
  DatasetFrameSource source(folder.Frames(), options);
  EXPECT_EQ(source.total(), 24u);
  const std::vector<FrameOrError> items = Drain(source);
  ASSERT_EQ(items.size(), 24u);
  for (int i = 0; i < 24; ++i) {
    ASSERT_TRUE(items[i].ok()) << i << ": " << items[i].status();
    EXPECT_EQ(items[i]->timestamp().seconds(), i);
    EXPECT_DOUBLE_EQ(items[i]->pose().translation().x(), i);
    EXPECT_EQ(FirstDepth(*items[i]), i + 1);
    EXPECT_EQ(items[i]->depth_encoding(), v1::DEPTH_ENCODING_RAW_U16);
    EXPECT_EQ(items[i]->color_encoding(), v1::COLOR_ENCODING_PNG);
    EXPECT_TRUE(items[i]->map().empty());  // the stream's to set
    EXPECT_EQ(items[i]->sequence(), 0u);
  }
  // After the end: the end again.
  absl::StatusOr<std::optional<FrameOrError>> after = source.Next();
  ASSERT_TRUE(after.ok());
  EXPECT_FALSE(after->has_value());
}

TEST(DatasetFrameSourceTest, MissingFileIsThatFramesErrorAndTheSourceGoesOn) {
  const TumFolder folder("frame_source_missing", 8);
  std::vector<dataset::Frame> frames = folder.Frames();
  ASSERT_EQ(frames.size(), 8u);
  fs::remove(frames[3].depth_path);
  frames[5].has_pose = false;
  DatasetFrameSource::Options options;
  options.depth_encoding = v1::DEPTH_ENCODING_ZSTD;
  DatasetFrameSource source(frames, options);
  const std::vector<FrameOrError> items = Drain(source);
  ASSERT_EQ(items.size(), 8u);
  for (int i = 0; i < 8; ++i) {
    if (i == 3) {
      EXPECT_EQ(items[i].status().code(), absl::StatusCode::kNotFound);
      EXPECT_NE(items[i].status().message().find("3.png"), std::string::npos);
    } else if (i == 5) {
      EXPECT_EQ(items[i].status().code(), absl::StatusCode::kFailedPrecondition);
    } else {
      ASSERT_TRUE(items[i].ok()) << i << ": " << items[i].status();
      EXPECT_EQ(items[i]->timestamp().seconds(), i);
      EXPECT_EQ(items[i]->depth_encoding(), v1::DEPTH_ENCODING_ZSTD);
    }
  }
}

TEST(DatasetFrameSourceTest, OpenKeepsEveryNthFrameUpToMaxFrames) {
  const TumFolder folder("frame_source_every", 20);
  FrameSourceOptions options;
  options.every = 3;
  options.max_frames = 4;
  options.depth_encoding = v1::DEPTH_ENCODING_PNG16;
  absl::StatusOr<std::unique_ptr<FrameSource>> source = OpenFrameSource(folder.path(), options);
  ASSERT_TRUE(source.ok()) << source.status();
  EXPECT_EQ((*source)->total(), 4u);
  const std::vector<FrameOrError> items = Drain(**source);
  ASSERT_EQ(items.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(items[i].ok()) << items[i].status();
    EXPECT_EQ(items[i]->timestamp().seconds(), 3 * i);
    EXPECT_EQ(items[i]->depth_encoding(), v1::DEPTH_ENCODING_PNG16);  // the file as stored
  }

  options.every = 1;
  options.max_frames = 0;
  source = OpenFrameSource(folder.path(), options);
  ASSERT_TRUE(source.ok()) << source.status();
  EXPECT_EQ((*source)->total(), 20u);
}

TEST(DatasetFrameSourceTest, ByDefaultA16BitPngGoesAsStoredAndAnythingElseIsDecoded) {
  const TumFolder folder("frame_source_as_stored", 3);
  std::vector<dataset::Frame> frames = folder.Frames();
  ASSERT_EQ(frames.size(), 3u);
  // Frame 1's depth file is an 8-bit PNG: decoded, and refused as a zstd frame would be.
  skimap::testing::ImWrite(frames[1].depth_path, cv::Mat(6, 8, CV_8UC1, cv::Scalar(7)));
  DatasetFrameSource source(frames, DatasetFrameSource::Options());
  const std::vector<FrameOrError> items = Drain(source);
  ASSERT_EQ(items.size(), 3u);
  for (const int i : {0, 2}) {
    ASSERT_TRUE(items[i].ok()) << i << ": " << items[i].status();
    EXPECT_EQ(items[i]->depth_encoding(), v1::DEPTH_ENCODING_PNG16);
    std::ifstream in(frames[i].depth_path, std::ios::binary);
    const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(items[i]->depth(), file);  // the bytes as stored
  }
  EXPECT_EQ(items[1].status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(items[1].status().message().find("not a 16-bit greyscale PNG"), std::string::npos)
      << items[1].status();
}

TEST(DatasetFrameSourceTest, OpenRejectsAFolderWithoutADataset) {
  absl::StatusOr<std::unique_ptr<FrameSource>> source =
      OpenFrameSource("/nonexistent-frame-source", FrameSourceOptions());
  EXPECT_EQ(source.status().code(), absl::StatusCode::kNotFound);
}

TEST(DatasetFrameSourceTest, DroppedBeforeItsEndStopsItsWorkers) {
  const TumFolder folder("frame_source_drop", 30);
  DatasetFrameSource::Options options;
  options.threads = 2;
  options.read_ahead = 3;
  for (int taken = 0; taken < 3; ++taken) {
    DatasetFrameSource source(folder.Frames(), options);
    for (int i = 0; i < taken; ++i) ASSERT_TRUE(source.Next().ok());
  }  // each destructor joins its workers (ASan / TSan see a leak or a race otherwise)
}

}  // namespace
}  // namespace skimap::client
