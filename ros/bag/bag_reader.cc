#include "ros/bag/bag_reader.h"

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace skimap::bag {

absl::StatusOr<std::unique_ptr<BagReader>> OpenBag(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return absl::NotFoundError(absl::StrCat("no bag at ", path));
  if (fs::is_directory(path, ec)) {
    std::vector<std::string> mcap, db3;
    for (const fs::directory_entry& e : fs::directory_iterator(path, ec)) {
      if (!e.is_regular_file()) continue;
      if (e.path().extension() == ".mcap") mcap.push_back(e.path());
      if (e.path().extension() == ".db3") db3.push_back(e.path());
    }
    std::sort(mcap.begin(), mcap.end());
    std::sort(db3.begin(), db3.end());
    if (!mcap.empty() && !db3.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": a rosbag2 folder with both .mcap and .db3 files; name one file"));
    }
    if (!mcap.empty()) return OpenMcapBag(mcap);
    if (!db3.empty()) return OpenSqliteBag(db3);
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": a folder without .mcap or .db3 files (not a rosbag2 folder)"));
  }
  std::ifstream in(path, std::ios::binary);
  char magic[13] = {};
  in.read(magic, sizeof magic);
  const absl::string_view head(magic, in.gcount());
  if (absl::StartsWith(head, "#ROSBAG V2.0")) return OpenRos1Bag(path);
  if (absl::StartsWith(head, "\x89MCAP0\r\n")) return OpenMcapBag({path});
  if (absl::StartsWith(head, "SQLite format")) return OpenSqliteBag({path});
  if (absl::StartsWith(head, "#ROSBAG")) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": a ROS 1 bag of another version than 2.0 (`rosbag fix` it)"));
  }
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": neither a ROS 1 bag (#ROSBAG V2.0) nor an MCAP or sqlite3 file"));
}

}  // namespace skimap::bag
