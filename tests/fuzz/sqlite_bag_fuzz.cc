// Fuzz target: ros/bag's reader of rosbag2's sqlite3 storage (sqlite_bag.cc, through
// OpenSqliteBag) and the CDR decoders behind it.
//
// Input: a .db3 file as is (the seeds are small bags: tests/ros/write_db3.py over
// write_bag.mjs --crop 8x6). It is written to a file of this process's own (SQLite reads
// files), opened read-only and immutable, and every message of the four frame types is
// decoded. Invariants: OpenBag and ForEach return (any status) without a sanitizer report,
// every message has a topic and exactly one decoded pointer, and nothing is written beside
// the database (no -journal or -wal file appears).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "ros/bag/bag_reader.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  static const std::string path = (std::filesystem::temp_directory_path() /
                                   ("sqlite_bag_fuzz_" + std::to_string(getpid()) + ".db3"))
                                      .string();
  // Removed when libFuzzer exits normally; a crash keeps it, beside its artifact.
  static const bool cleanup = std::atexit([] { std::remove(path.c_str()); }) == 0;
  (void)cleanup;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) fuzz::Fail("cannot write the input file");
  if (size > 0 && std::fwrite(data, 1, size, f) != size) fuzz::Fail("short write");
  std::fclose(f);
  absl::StatusOr<std::unique_ptr<bag::BagReader>> bag = bag::OpenSqliteBag({path});
  if (bag.ok()) {
    std::vector<std::string> topics;
    for (const bag::BagTopic& t : (*bag)->topics()) {
      if (bag::IsFrameType(t.type)) topics.push_back(t.name);
    }
    (void)(*bag)->ForEach(topics, [](const bag::BagMessage& m) {
      if (m.topic == nullptr) fuzz::Fail("a message without a topic");
      const int set = (m.image != nullptr) + (m.compressed != nullptr) + (m.info != nullptr) +
                      (m.tf != nullptr);
      if (set != 1) fuzz::Fail("a message with other than one decoded pointer");
      return absl::OkStatus();
    });
  }
  for (const char* suffix : {"-journal", "-wal"}) {
    if (std::filesystem::exists(path + suffix)) fuzz::Fail("SQLite wrote beside the bag");
  }
  return 0;
}
