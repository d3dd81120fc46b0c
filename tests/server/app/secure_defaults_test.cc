// Secure defaults of skimapd: loopback unless told otherwise.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <string>

#include "server/core/auth/listen_address.h"
#include "tests/common/skimapd_process.h"

namespace skimap::testing {
namespace {

TEST(ListenAddressTest, OnlyLoopbackAddressesCountAsLocal) {
  for (const char* local : {"127.0.0.1:50051", "127.1.2.3:0", "localhost:80", "[::1]:50051",
                            "unix:/tmp/skimapd.sock", "ipv4:127.0.0.1:1"}) {
    EXPECT_TRUE(server::IsLoopbackAddress(local)) << local;
  }
  for (const char* remote :
       {"0.0.0.0:50051", "[::]:50051", ":50051", "10.0.0.1:50051", "128.0.0.1:1", "127.0.0.1",
        "127.0.0.256:1", "example.com:50051", "127.0.0.1.evil.com:1"}) {
    EXPECT_FALSE(server::IsLoopbackAddress(remote)) << remote;
  }
}

// Runs skimapd with `flags` until it exits (it must, within the test's timeout) and
// returns its exit code and what it printed.
std::pair<int, std::string> RunToExit(const std::string& flags) {
  const std::string command = std::string(SKIMAPD_PATH) + " " + flags + " 2>&1";
  FILE* out = popen(command.c_str(), "r");
  std::string text;
  char buf[512];
  while (fgets(buf, sizeof buf, out) != nullptr) text += buf;
  const int status = pclose(out);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text};
}

TEST(SecureDefaultsTest, SkimapdRefusesToListenBeyondLoopbackWithoutInsecure) {
  const std::string dir = std::filesystem::temp_directory_path() / "skimapd_secure_defaults";
  const auto [code, text] =
      RunToExit("--address=0.0.0.0:" + std::to_string(FreePort()) + " --data_dir=" + dir);
  EXPECT_EQ(code, 1);
  EXPECT_NE(text.find("beyond loopback"), std::string::npos) << text;
  EXPECT_NE(text.find("--insecure"), std::string::npos) << text;
  std::filesystem::remove_all(dir);
}

TEST(SecureDefaultsTest, InsecureAllowsEveryInterface) {
  SkimapdProcess server(SKIMAPD_PATH, {"--insecure"});
  // Start() binds 127.0.0.1; the flag must not break that, and "0.0.0.0" is allowed too.
  ASSERT_TRUE(server.Start().ok());
  SkimapdProcess wide(SKIMAPD_PATH, {"--insecure"});
  EXPECT_TRUE(wide.StartOn("0.0.0.0").ok());
}

}  // namespace
}  // namespace skimap::testing
