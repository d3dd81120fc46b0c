#include "server/http/http_server.h"

#include <httplib.h>
#include <sys/socket.h>

#include <chrono>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "base/echo.h"
#include "server/core/auth/access.h"
#include "server/core/auth/listen_address.h"
#include "server/http/http_call.h"
#include "server/http/http_status.h"
#include "server/http/rest_messages.h"

namespace skimap::server {
namespace {

constexpr char kExposedHeaders[] =
    "X-Skimap-Resolution, X-Skimap-Origin, X-Skimap-Width, X-Skimap-Height, "
    "X-Skimap-Z-Offset, X-Skimap-Z-Scale";

// "host:port" or "[v6]:port" -> host and port; false if malformed.
bool SplitAddress(const std::string& address, std::string* host, int* port) {
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos || !absl::SimpleAtoi(address.substr(colon + 1), port) ||
      *port < 0 || *port > 65535) {
    return false;
  }
  *host = address.substr(0, colon);
  if (host->size() >= 2 && host->front() == '[' && host->back() == ']') {
    *host = host->substr(1, host->size() - 2);
  }
  if (host->empty()) *host = "0.0.0.0";
  return true;
}

// An OpenAPI path template as a regex: {name} matches one segment without '/' or ':'.
std::regex CompileTemplate(const std::string& path, std::vector<std::string>* parameters) {
  std::string pattern;
  for (size_t i = 0; i < path.size(); ++i) {
    if (path[i] == '{') {
      const size_t end = path.find('}', i);
      parameters->push_back(path.substr(i + 1, end - i - 1));
      pattern += "([^/:]+)";
      i = end;
    } else if (absl::ascii_isalnum(path[i]) || path[i] == '/' || path[i] == '_') {
      pattern += path[i];
    } else {
      pattern += absl::StrCat("\\", std::string(1, path[i]));
    }
  }
  return std::regex(pattern);
}

void WriteError(httplib::Response& response, const absl::Status& status, int http_code = 0) {
  const v1::RestError error = ToRestError(status, http_code);
  response.status = error.code();
  response.set_content(ToJson(error), "application/json");
}

}  // namespace

HttpServer::HttpServer(const Options& options, std::vector<RestRoute> routes)
    : options_(options), routes_(std::move(routes)) {
  for (const RestRoute& route : routes_) {
    CompiledRoute compiled;
    compiled.pattern = CompileTemplate(route.path, &compiled.parameters);
    compiled_.push_back(std::move(compiled));
  }
}

absl::StatusOr<std::unique_ptr<HttpServer>> HttpServer::Start(const Options& options,
                                                              std::vector<RestRoute> routes) {
  if (absl::Status s = CheckListenAddress(
          options.address, options.insecure || options.auth != nullptr, "--http_address");
      !s.ok()) {
    return s;
  }
  std::string host;
  int port = 0;
  if (!SplitAddress(options.address, &host, &port)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--http_address ", Echo(options.address), " is not host:port"));
  }
  if (options.threads < 1 || options.max_body_bytes < 1) {
    return absl::InvalidArgumentError("HTTP threads and body limit must be >= 1");
  }
  std::unique_ptr<HttpServer> s(new HttpServer(options, std::move(routes)));
  if (options.tls.enabled()) {
    // Read first for clear errors; httplib reads the same files again.
    absl::StatusOr<auth::TlsFiles::Pem> pem = options.tls.Read();
    if (!pem.ok()) return pem.status();
    const std::string& ca = options.tls.client_ca;
    auto https = std::make_unique<httplib::SSLServer>(
        options.tls.cert.c_str(), options.tls.key.c_str(), ca.empty() ? nullptr : ca.c_str());
    if (!https->is_valid()) {
      return absl::InvalidArgumentError(
          "--tls_cert / --tls_key / --tls_client_ca: OpenSSL refused them (a key that does not "
          "match the certificate, or a file that is not a PEM certificate or key)");
    }
    s->http_ = std::move(https);
  } else {
    s->http_ = std::make_unique<httplib::Server>();
  }
  if (!options.web_root.empty()) {
    absl::StatusOr<StaticFiles> files = StaticFiles::Open(options.web_root);
    if (!files.ok()) return files.status();
    s->files_ = *std::move(files);
  }
  httplib::Server& http = *s->http_;
  const int threads = options.threads;
  http.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  http.set_payload_max_length(options.max_body_bytes);
  http.set_keep_alive_timeout(2);  // bounds how long Stop waits for idle connections
  // Only SO_REUSEADDR: a second server on the same port must fail, not share it.
  http.set_socket_options([](int sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  HttpServer* self = s.get();
  http.set_pre_routing_handler(
      [self](const httplib::Request& request, httplib::Response& response) {
        return self->ApplyCors(request, response) ? httplib::Server::HandlerResponse::Handled
                                                  : httplib::Server::HandlerResponse::Unhandled;
      });
  auto dispatch = [self](const httplib::Request& request, httplib::Response& response) {
    self->Dispatch(request, response);
  };
  http.Get(".*", dispatch).Post(".*", dispatch).Put(".*", dispatch).Patch(".*", dispatch);
  http.Delete(".*", dispatch).Options(".*", dispatch);
  // Errors httplib answers itself (413 above the body limit, 400 unparsable requests):
  // the same RestError body. Replies that already have one are left alone.
  const size_t limit = options.max_body_bytes;
  http.set_error_handler(httplib::Server::HandlerWithResponse(
      [limit](const httplib::Request& request, httplib::Response& response) {
        if (!response.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
        if (response.status == 413) {
          WriteError(response, BodyTooLargeError(absl::StrCat(
                                   "body: ", request.get_header_value("Content-Length"),
                                   " bytes exceed the limit of ", limit,
                                   " bytes (skimapd --http_max_body_mb)")));
        } else if (response.status == 404) {
          WriteError(response, absl::NotFoundError("no such route"));
        } else {
          WriteError(response,
                     absl::InvalidArgumentError(
                         "malformed HTTP request (a request line or header that does not parse, "
                         "or a body without Content-Length)"),
                     response.status);
        }
        return httplib::Server::HandlerResponse::Handled;
      }));
  http.set_exception_handler(
      [](const httplib::Request&, httplib::Response& response, std::exception_ptr) {
        WriteError(response, absl::InternalError("the request failed inside the server"));
      });
  s->port_ = port == 0 ? http.bind_to_any_port(host) : (http.bind_to_port(host, port) ? port : -1);
  if (s->port_ <= 0) {
    return absl::UnavailableError(
        absl::StrCat("cannot listen on ", options.address, " (--http_address)"));
  }
  s->listener_ = std::thread([self] { self->http_->listen_after_bind(); });
  // Stop() only stops a running listener: wait until it runs.
  for (int i = 0; i < 5000 && !http.is_running(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return s;
}

HttpServer::~HttpServer() { Stop(); }

void HttpServer::Stop() {
  http_->stop();
  if (listener_.joinable()) listener_.join();
}

void HttpServer::Dispatch(const httplib::Request& request, httplib::Response& response) const {
  HttpCall call(request, response, options_.metrics);  // request id, metrics, access line
  const std::string method = request.method == "HEAD" ? "GET" : request.method;
  std::vector<std::string> allowed;
  for (size_t i = 0; i < routes_.size(); ++i) {
    std::smatch match;
    if (!std::regex_match(request.path, match, compiled_[i].pattern)) continue;
    if (routes_[i].method != method) {
      allowed.push_back(routes_[i].method);
      continue;
    }
    // The URL's query only: httplib also adds the fields of a form-encoded body to
    // request.params, and `curl -d '{json}'` sends JSON as exactly that.
    httplib::Params query;
    if (const size_t q = request.target.find('?'); q != std::string::npos) {
      httplib::detail::parse_query_text(request.target.substr(q + 1), query);
    }
    RestCall rest{
        .query = query, .body = request.body, .accept = request.get_header_value("Accept")};
    for (size_t p = 0; p < compiled_[i].parameters.size(); ++p) {
      rest.path[compiled_[i].parameters[p]] = match[p + 1].str();
    }
    const auto map = rest.path.find("map");
    call.SetRoute(absl::StrCat(routes_[i].method, " ", routes_[i].path),
                  map == rest.path.end() ? "" : absl::StrCat("maps/", map->second.substr(0, 256)));
    const absl::StatusOr<auth::Grant> grant = Authorize(request, i, rest.path);
    if (!grant.ok()) {
      if (absl::IsUnauthenticated(grant.status())) {
        response.set_header("WWW-Authenticate", "Bearer realm=\"skimapd\"");
      }
      return WriteError(response, grant.status());
    }
    rest.grant = &*grant;
    absl::StatusOr<RestReply> reply = routes_[i].handler(rest);
    if (!reply.ok()) return WriteError(response, reply.status());
    return Answer(*std::move(reply), response);
  }
  if (allowed.empty() && files_ && method == "GET" && !absl::StartsWith(request.path, "/v1/")) {
    call.SetRoute("static", "");
    absl::StatusOr<RestReply> file = files_->Get(request.path);
    if (!file.ok()) return WriteError(response, file.status());
    return Answer(*std::move(file), response);
  }
  if (allowed.empty()) {
    return WriteError(response, absl::NotFoundError(absl::StrCat("no route ", request.method, " ",
                                                                 Echo(request.path))));
  }
  response.set_header("Allow", absl::StrJoin(allowed, ", "));
  if (method == "OPTIONS") {
    response.status = 204;
    return;
  }
  WriteError(response,
             absl::UnimplementedError(absl::StrCat("method ", request.method, " is not allowed on ",
                                                   Echo(request.path), "; it takes ",
                                                   absl::StrJoin(allowed, ", "))),
             405);
}

absl::StatusOr<auth::Grant> HttpServer::Authorize(
    const httplib::Request& request, size_t i,
    const std::map<std::string, std::string>& path) const {
  if (options_.auth == nullptr) return auth::Grant::Everything();
  const std::optional<auth::Role> role =
      auth::RouteRole(routes_[i].method, routes_[i].path, options_.metrics_public);
  if (!role.has_value()) return auth::Grant::Everything();
  const std::string authorization = request.get_header_value("Authorization");
  if (auto map = path.find("map"); map != path.end()) {
    return options_.auth->AuthorizeMap(authorization, *role, "maps/" + map->second);
  }
  return options_.auth->Authorize(authorization, *role);
}

void HttpServer::Answer(RestReply reply, httplib::Response& response) {
  response.status = 200;
  for (const auto& [name, value] : reply.headers) response.set_header(name, value);
  if (!reply.stream) {
    response.set_content(std::move(reply.body), reply.content_type);
    return;
  }
  response.set_chunked_content_provider(
      reply.content_type, [stream = std::move(reply.stream)](size_t, httplib::DataSink& sink) {
        stream([&sink](std::string_view piece) {
          return sink.is_writable() && sink.write(piece.data(), piece.size());
        });
        sink.done();
        return true;
      });
}

bool HttpServer::OriginAllowed(const std::string& origin) const {
  for (const std::string& allowed : options_.cors_origins) {
    if (allowed == "*" || allowed == origin) return true;
  }
  return false;
}

std::string HttpServer::MethodsFor(const std::string& path) const {
  std::vector<std::string> methods;
  for (size_t i = 0; i < routes_.size(); ++i) {
    if (std::regex_match(path, compiled_[i].pattern)) methods.push_back(routes_[i].method);
  }
  return absl::StrJoin(methods, ", ");
}

bool HttpServer::ApplyCors(const httplib::Request& request, httplib::Response& response) const {
  const std::string origin = request.get_header_value("Origin");
  if (origin.empty()) return false;
  const bool allowed = OriginAllowed(origin);
  response.set_header("Vary", "Origin");
  if (allowed) {
    response.set_header("Access-Control-Allow-Origin", origin);
    response.set_header("Access-Control-Expose-Headers", kExposedHeaders);
  }
  if (request.method != "OPTIONS" || !request.has_header("Access-Control-Request-Method")) {
    return false;  // CORS headers only
  }
  if (!allowed) {
    WriteError(response, absl::PermissionDeniedError(
                             absl::StrCat("origin ", Echo(origin),
                                          " may not call this server from a browser (skimapd "
                                          "--http_cors_origins)")));
    return true;
  }
  const std::string methods = MethodsFor(request.path);
  if (methods.empty()) {
    WriteError(response, absl::NotFoundError(absl::StrCat("no route ", Echo(request.path))));
    return true;
  }
  response.status = 204;
  response.set_header("Access-Control-Allow-Methods", methods);
  const std::string headers = request.get_header_value("Access-Control-Request-Headers");
  response.set_header("Access-Control-Allow-Headers",
                      headers.empty() ? "Content-Type, Accept" : headers);
  response.set_header("Access-Control-Max-Age", "600");
  return true;
}

}  // namespace skimap::server
