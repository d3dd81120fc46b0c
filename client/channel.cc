#include "client/channel.h"

#include <grpcpp/support/client_interceptor.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace skimap::client {
namespace {

namespace gx = grpc::experimental;

// Adds `authorization: Bearer <token>` to the initial metadata of every call.
class BearerInterceptor final : public gx::Interceptor {
 public:
  explicit BearerInterceptor(const std::string* header) : header_(header) {}
  void Intercept(gx::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            gx::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->emplace("authorization", *header_);
    }
    methods->Proceed();
  }

 private:
  const std::string* const header_;  // owned by the factory, which the channel keeps
};

class BearerInterceptorFactory final : public gx::ClientInterceptorFactoryInterface {
 public:
  explicit BearerInterceptorFactory(const std::string& token) : header_("Bearer " + token) {}
  gx::Interceptor* CreateClientInterceptor(gx::ClientRpcInfo*) override {
    return new BearerInterceptor(&header_);
  }

 private:
  const std::string header_;
};

absl::StatusOr<std::string> ReadFile(const std::string& path, const char* flag) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(flag, " ", path, ": cannot be read"));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

absl::StatusOr<Connection> Connection::FromFiles(const Files& files) {
  Connection c;
  if (files.tls_cert.empty() != files.tls_key.empty()) {
    return absl::InvalidArgumentError("--tls_cert and --tls_key go together: give both or none");
  }
  c.tls = !files.tls_ca.empty() || !files.tls_cert.empty();
  for (auto [path, flag, out] : {std::tuple{&files.tls_ca, "--tls_ca", &c.tls_ca_pem},
                                 std::tuple{&files.tls_cert, "--tls_cert", &c.tls_cert_pem},
                                 std::tuple{&files.tls_key, "--tls_key", &c.tls_key_pem}}) {
    if (path->empty()) continue;
    absl::StatusOr<std::string> text = ReadFile(*path, flag);
    if (!text.ok()) return text.status();
    *out = *std::move(text);
  }
  if (!files.token_file.empty()) {
    absl::StatusOr<std::string> text = ReadFile(files.token_file, "--token_file");
    if (!text.ok()) return text.status();
    const std::string first_line = text->substr(0, text->find('\n'));
    c.token = std::string(absl::StripAsciiWhitespace(first_line));
    if (c.token.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--token_file ", files.token_file, ": the first line holds no token"));
    }
  } else if (const char* env = std::getenv("SKIMAP_TOKEN"); env != nullptr) {
    c.token = std::string(absl::StripAsciiWhitespace(env));
  }
  return c;
}

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& target, int max_message_bytes,
                                           const Connection& connection) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(max_message_bytes);
  args.SetMaxSendMessageSize(max_message_bytes);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (connection.tls) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = connection.tls_ca_pem;
    ssl.pem_cert_chain = connection.tls_cert_pem;
    ssl.pem_private_key = connection.tls_key_pem;
    credentials = grpc::SslCredentials(ssl);
  }
  if (connection.token.empty()) return grpc::CreateCustomChannel(target, credentials, args);
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<BearerInterceptorFactory>(connection.token));
  return grpc::experimental::CreateCustomChannelWithInterceptors(target, credentials, args,
                                                                 std::move(interceptors));
}

}  // namespace skimap::client
