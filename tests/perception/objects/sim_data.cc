#include "tests/perception/objects/sim_data.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "sim/generator.h"
#include "tests/common/test_temp_dir.h"

namespace skimap::objects::testing {
namespace fs = std::filesystem;

std::string MiniDataset() {
  const fs::path root = fs::path(SKIMAP_OBJECTS_TEST_DATA_DIR) / "mini";
  const fs::path done = root / ".complete";
  fs::create_directories(SKIMAP_OBJECTS_TEST_DATA_DIR);
  const std::string lock_path = std::string(SKIMAP_OBJECTS_TEST_DATA_DIR) + "/.lock";
  const int fd = open(lock_path.c_str(), O_CREAT | O_RDWR, 0644);
  EXPECT_GE(fd, 0);
  flock(fd, LOCK_EX);
  // A cache from before the sim wrote textured models is rendered again.
  if (!fs::exists(done) || !fs::exists(root / "models" / "textured")) {
    fs::remove_all(root);
    sim::GeneratorOptions o;
    o.out_dir = root.string();
    o.preset = "mini";
    o.train_frames = kTrainFrames;
    o.scenes = 0;
    o.threads = 2;
    absl::StatusOr<sim::GeneratorStats> s = sim::Generate(o);
    EXPECT_TRUE(s.ok()) << s.status();
    if (s.ok()) std::ofstream(done) << "mini, train_frames " << kTrainFrames << "\n";
  }
  flock(fd, LOCK_UN);
  close(fd);
  return root.string();
}

std::string TempDir() { return skimap::testing::TestTempDir("skimap_objects"); }

}  // namespace skimap::objects::testing
