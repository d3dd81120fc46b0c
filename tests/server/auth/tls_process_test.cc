// TLS and mTLS of a real skimapd (--tls_cert, --tls_key, --tls_client_ca) on both ports,
// with CAs made at test time (test_pki.h): the good client connects; a plain-text client
// fails; under mTLS a client without a certificate, or with one from another CA, fails the
// handshake, on gRPC and on HTTPS alike.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <string>

#include "client/map_client.h"
#include "tests/common/skimapd_process.h"
#include "tests/server/auth/test_pki.h"
#include "tests/server/http/http_client.h"

namespace skimap::testing {
namespace {

class TlsProcessTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // The HTTPS client writes with OpenSSL's write(2): a server that refused the handshake
    // and closed would otherwise kill this process with SIGPIPE.
    signal(SIGPIPE, SIG_IGN);
    pki_ = new TestPki();
    ASSERT_TRUE(pki_->ok());
    ASSERT_TRUE(pki_->Issue("server", "ca", /*server=*/true));
    ASSERT_TRUE(pki_->Issue("client", "ca", /*server=*/false));
    ASSERT_TRUE(pki_->Issue("stranger", "other", /*server=*/false));
  }
  static void TearDownTestSuite() {
    delete pki_;
    pki_ = nullptr;
  }

  // A skimapd serving TLS; with mTLS, client certificates of "ca" are required.
  std::unique_ptr<SkimapdProcess> Start(bool mtls) {
    std::vector<std::string> flags = {"--worker_threads=1",
                                      "--tls_cert=" + pki_->Path("server.pem"),
                                      "--tls_key=" + pki_->Path("server.key")};
    if (mtls) flags.push_back("--tls_client_ca=" + pki_->Path("ca.pem"));
    auto server = std::make_unique<SkimapdProcess>(SKIMAPD_PATH, flags);
    server->set_connection(Client(mtls ? "client" : ""));
    EXPECT_TRUE(server->Start().ok());
    return server;
  }
  // A TLS connection trusting "ca", with the certificate `cert` ("" = none).
  static client::Connection Client(const std::string& cert) {
    client::Connection c{.tls = true, .tls_ca_pem = pki_->Read("ca.pem")};
    if (!cert.empty()) {
      c.tls_cert_pem = pki_->Read(cert + ".pem");
      c.tls_key_pem = pki_->Read(cert + ".key");
    }
    return c;
  }
  static absl::Status ListMaps(const SkimapdProcess& server, const client::Connection& c) {
    return client::MapClient::Connect(server.address(),
                                      {.timeout = absl::Seconds(5), .connection = c})
        ->ListAllMaps()
        .status();
  }
  // GET /healthz over HTTPS trusting "ca", with the certificate `cert` ("" = none); the
  // HTTP status, or -1 if no answer came (a failed handshake).
  static int Healthz(const SkimapdProcess& server, const std::string& cert) {
    std::unique_ptr<httplib::SSLClient> https;
    if (cert.empty()) {
      https = std::make_unique<httplib::SSLClient>("127.0.0.1", server.http_port());
    } else {
      https = std::make_unique<httplib::SSLClient>(
          "127.0.0.1", server.http_port(), pki_->Path(cert + ".pem"), pki_->Path(cert + ".key"));
    }
    https->set_ca_cert_path(pki_->Path("ca.pem").c_str());
    https->enable_server_certificate_verification(true);
    https->set_connection_timeout(5);
    // A refused handshake may leave the client reading: without this it waits out
    // cpp-httplib's default read timeout of 300 s.
    https->set_read_timeout(10);
    https->set_write_timeout(10);
    httplib::Result r = https->Get("/healthz");
    return r ? r->status : -1;
  }

  static TestPki* pki_;
};
TestPki* TlsProcessTest::pki_ = nullptr;

TEST_F(TlsProcessTest, TlsServesTheGoodClientAndRefusesPlainText) {
  std::unique_ptr<SkimapdProcess> server = Start(/*mtls=*/false);
  EXPECT_TRUE(ListMaps(*server, Client("")).ok());
  const absl::Status plain = ListMaps(*server, client::Connection{});
  EXPECT_EQ(plain.code(), absl::StatusCode::kUnavailable) << plain;
  EXPECT_EQ(Healthz(*server, ""), 200);
  httplib::Client http("127.0.0.1", server->http_port());
  http.set_connection_timeout(5);
  httplib::Result r = http.Get("/healthz");
  EXPECT_FALSE(r && r->status == 200);
  // A client that trusts another CA refuses the server.
  client::Connection wrong_ca{.tls = true, .tls_ca_pem = pki_->Read("other.pem")};
  EXPECT_EQ(ListMaps(*server, wrong_ca).code(), absl::StatusCode::kUnavailable);
}

TEST_F(TlsProcessTest, MutualTlsNeedsACertificateFromTheClientCa) {
  std::unique_ptr<SkimapdProcess> server = Start(/*mtls=*/true);
  EXPECT_TRUE(ListMaps(*server, Client("client")).ok());
  EXPECT_EQ(ListMaps(*server, Client("")).code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(ListMaps(*server, Client("stranger")).code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(ListMaps(*server, client::Connection{}).code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(Healthz(*server, "client"), 200);
  EXPECT_EQ(Healthz(*server, ""), -1);
  EXPECT_EQ(Healthz(*server, "stranger"), -1);
}

TEST_F(TlsProcessTest, TlsAndTokensTogether) {
  const std::string tokens = pki_->Path("tokens");
  std::ofstream(tokens) << "tls-admin-token-0123456789 admin\n";
  SkimapdProcess server(SKIMAPD_PATH,
                        {"--tls_cert=" + pki_->Path("server.pem"),
                         "--tls_key=" + pki_->Path("server.key"), "--auth_tokens_file=" + tokens});
  server.set_connection(Client(""));
  ASSERT_TRUE(server.Start().ok());
  client::Connection with_token = Client("");
  with_token.token = "tls-admin-token-0123456789";
  EXPECT_TRUE(ListMaps(server, with_token).ok());
  EXPECT_EQ(ListMaps(server, Client("")).code(), absl::StatusCode::kUnauthenticated);
}

TEST_F(TlsProcessTest, BadTlsFlagsStopTheStart) {
  for (const std::string& flags :
       {"--tls_cert=" + pki_->Path("server.pem"),
        "--tls_cert=" + pki_->Path("server.pem") + " --tls_key=" + pki_->Path("missing.key"),
        "--tls_cert=" + pki_->Path("server.pem") + " --tls_key=" + pki_->Path("client.key")}) {
    const std::string dir = pki_->Path("data");
    const std::string command =
        absl::StrCat(SKIMAPD_PATH, " --data_dir=", dir, " --address=127.0.0.1:", FreePort(),
                     " --http_address=127.0.0.1:", FreePort(), " ", flags, " 2>&1");
    FILE* out = popen(command.c_str(), "r");
    std::string text;
    char buf[512];
    while (fgets(buf, sizeof buf, out) != nullptr) text += buf;
    const int status = pclose(out);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << flags << "\n" << text;
    EXPECT_THAT(text, ::testing::HasSubstr("--tls_")) << text;
  }
}

}  // namespace
}  // namespace skimap::testing
