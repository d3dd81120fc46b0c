// TestPki: certificate authorities and certificates made at test time with the openssl
// command-line tool (Debian's openssl), in a temp directory removed afterwards.
//
//   TestPki pki;                                   // CA "ca", CA "other"
//   pki.Issue("server", "ca", /*server=*/true);    // server.pem / server.key, SAN 127.0.0.1
//   pki.Issue("client", "ca", /*server=*/false);   // client.pem / client.key
//   pki.Path("ca.pem");
//
// Thread safety: a test-thread object.
#ifndef TESTS_SERVER_AUTH_TEST_PKI_H_
#define TESTS_SERVER_AUTH_TEST_PKI_H_

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "absl/strings/str_cat.h"

namespace skimap::testing {

class TestPki {
 public:
  TestPki() : dir_(std::filesystem::temp_directory_path() / absl::StrCat("skimap_pki_", getpid())) {
    std::filesystem::create_directories(dir_);
    ok_ = MakeCa("ca") && MakeCa("other");
  }
  ~TestPki() { std::filesystem::remove_all(dir_); }
  TestPki(const TestPki&) = delete;
  TestPki& operator=(const TestPki&) = delete;

  // False if openssl failed (the test should stop).
  bool ok() const { return ok_; }

  // NAME.key and NAME.pem signed by CA `ca` ("ca" or "other"); a server certificate names
  // 127.0.0.1 and localhost.
  bool Issue(const std::string& name, const std::string& ca, bool server) {
    const std::string ext = Path(name + ".ext");
    std::ofstream(ext) << (server ? "subjectAltName=IP:127.0.0.1,DNS:localhost\n"
                                    "extendedKeyUsage=serverAuth\n"
                                  : "extendedKeyUsage=clientAuth\n");
    return Run(absl::StrCat("openssl req -newkey rsa:2048 -nodes -keyout ", Path(name + ".key"),
                            " -out ", Path(name + ".csr"), " -subj /CN=", name)) &&
           Run(absl::StrCat("openssl x509 -req -in ", Path(name + ".csr"), " -CA ",
                            Path(ca + ".pem"), " -CAkey ", Path(ca + ".key"),
                            " -CAcreateserial -days 2 -out ", Path(name + ".pem"), " -extfile ",
                            ext));
  }

  std::string Path(const std::string& file) const { return (dir_ / file).string(); }
  std::string Read(const std::string& file) const {
    std::ifstream in(Path(file));
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

 private:
  bool MakeCa(const std::string& name) {
    return Run(absl::StrCat("openssl req -x509 -newkey rsa:2048 -nodes -days 2 -keyout ",
                            Path(name + ".key"), " -out ", Path(name + ".pem"), " -subj /CN=", name,
                            "-test-ca"));
  }
  static bool Run(const std::string& command) {
    return std::system((command + " >/dev/null 2>&1").c_str()) == 0;
  }

  const std::filesystem::path dir_;
  bool ok_ = false;
};

}  // namespace skimap::testing

#endif  // TESTS_SERVER_AUTH_TEST_PKI_H_
