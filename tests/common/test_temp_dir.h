// TestTempDir(prefix): a scratch folder for the running test, <system temp>/<prefix>_<pid>_
// <test name> (outside a test, <prefix>_<pid>), created empty by the first call and the same
// folder, as it is, on later calls in the same test. Every folder it made is
// removed when the test program exits normally after all its tests passed, and kept, for a
// look, when one failed (or the program aborted). Without this the suites left a few hundred
// folders in /tmp per run of the test command. Thread safety: call it from test threads; the
// removal runs once, at exit, in the process that made the folders (never in a forked child).
#ifndef TESTS_COMMON_TEST_TEMP_DIR_H_
#define TESTS_COMMON_TEST_TEMP_DIR_H_

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace skimap::testing {

class TestTempDirs {
 public:
  // Constructed on first use, that is after GoogleTest's UnitTest singleton, so destroyed
  // before it: the verdict is still there to read.
  static TestTempDirs& Get() {
    static TestTempDirs dirs;
    return dirs;
  }

  // Registers `dir`; false if it was already registered (made earlier in this test).
  bool Add(const std::filesystem::path& dir) {
    std::lock_guard<std::mutex> lock(mu_);
    if (std::find(dirs_.begin(), dirs_.end(), dir) != dirs_.end()) return false;
    dirs_.push_back(dir);
    return true;
  }

  ~TestTempDirs() {
    if (getpid() != owner_ || !::testing::UnitTest::GetInstance()->Passed()) return;
    for (const std::filesystem::path& dir : dirs_) {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  }

 private:
  TestTempDirs() : owner_(getpid()) {}
  const pid_t owner_;
  std::mutex mu_;
  std::vector<std::filesystem::path> dirs_;
};

inline std::string TestTempDir(std::string_view prefix) {
  std::string name = std::string(prefix) + "_" + std::to_string(getpid());
  if (const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info()) {
    name += std::string("_") + info->name();
  }
  for (char& c : name) {
    if (c == '/') c = '_';  // parameterised tests are named "Name/0"
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / name;
  if (TestTempDirs::Get().Add(dir)) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  return dir.string();
}

}  // namespace skimap::testing

#endif  // TESTS_COMMON_TEST_TEMP_DIR_H_
