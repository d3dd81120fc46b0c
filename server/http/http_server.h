// HttpServer: the HTTP/1.1 adapter of skimapd (cpp-httplib): binds one address, runs a
// pool of threads, enforces the body limit and the CORS policy, and dispatches requests
// to a route table (rest_routes.h) of its own matcher, so that a known path with another
// method answers 405 with an Allow header and an unknown path 404, both as RestError JSON.
// Every error, whatever produced it, answers a RestError body (http_status.h).
//
//   absl::StatusOr<std::unique_ptr<HttpServer>> http =
//       HttpServer::Start({.address = "127.0.0.1:0"}, MakeRestRoutes(maps, objects));
//   int port = (*http)->port();
//   (*http)->Stop();
//
// CORS: a request whose Origin is in `cors_origins` (or any, with "*") gets
// Access-Control-Allow-Origin; a preflight (OPTIONS with Access-Control-Request-Method)
// from such an origin answers 204 with the methods of the path; from another origin 403.
// Requests without Origin (curl, servers) are not affected.
//
// The viewer: with `web_root`, a GET of a path no route has (outside /v1/) answers the
// file from that directory (static_files.h: MIME types, caching, no path outside it).
// A route may answer a stream (RestReply::stream, server-sent events): it is sent with
// chunked transfer encoding on the request's thread.
//
// Thread safety: handlers run concurrently on the pool; Stop may be called from any
// thread and is idempotent.
#ifndef SERVER_HTTP_HTTP_SERVER_H_
#define SERVER_HTTP_HTTP_SERVER_H_

#include <map>
#include <memory>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "server/core/auth/authorizer.h"
#include "server/core/auth/tls_files.h"
#include "server/core/metrics/metrics.h"
#include "server/http/rest_route.h"
#include "server/http/static_files.h"

// cpp-httplib stays out of this header: <httplib.h> includes <resolv.h>, whose `_res`
// macro breaks headers included after it (Eigen's).
namespace httplib {
class Server;
struct Request;
struct Response;
}  // namespace httplib

namespace skimap::server {

class HttpServer {
 public:
  struct Options {
    // host:port; port 0 = any free port. Loopback unless `insecure` or `auth`
    // (listen_address.h).
    std::string address = "127.0.0.1:8080";
    bool insecure = false;
    // Bearer-token authorization (header `Authorization: Bearer <token>`) of every route
    // but the public ones (server/core/auth/access.h); not owned, outlives the server; null = none.
    // 401 (with WWW-Authenticate) for a missing or unknown token, 403 for a role too low
    // or a {map} outside the token's scope.
    const auth::Authorizer* auth = nullptr;
    // GET /metrics readable without a token (with `auth`); else it needs the read role.
    bool metrics_public = true;
    // HTTPS with tls.cert and tls.key; client certificates required and verified against
    // tls.client_ca when given (mTLS). Plain HTTP without.
    auth::TlsFiles tls;
    int threads = 8;                           // requests served at once, >= 1
    size_t max_body_bytes = size_t{32} << 20;  // larger bodies: 413
    // Origins allowed to call from a browser ("https://viewer.example:8443"), or "*" for
    // any; empty: none (same-origin pages only).
    std::vector<std::string> cors_origins;
    // The viewer's files (web/dist); "" = none. Must hold index.html.
    std::string web_root;
    // Request latency by route and status (not owned; outlives the server); null: none.
    // Request ids (X-Request-Id) and access log lines (http_call.h) are on either way.
    Metrics* metrics = nullptr;
  };

  // Binds and starts serving `routes` on the pool. FailedPrecondition for an address
  // beyond loopback without `insecure` or `auth`; InvalidArgument for a malformed address
  // or options; NotFound for a web_root without index.html; the TLS files' errors
  // (TlsFiles::Read); Unavailable if the address cannot be bound.
  static absl::StatusOr<std::unique_ptr<HttpServer>> Start(const Options& options,
                                                           std::vector<RestRoute> routes);
  ~HttpServer();  // Stop()

  int port() const { return port_; }
  // The routes served, in the order given (for the OpenAPI check).
  const std::vector<RestRoute>& routes() const { return routes_; }

  // Stops accepting connections and waits for the requests being served.
  void Stop();

 private:
  struct CompiledRoute {
    std::regex pattern;
    std::vector<std::string> parameters;  // names of the template's {parameters}, in order
  };

  HttpServer(const Options& options, std::vector<RestRoute> routes);
  // The grant of the request for route `i` (Grant::Everything() without auth or for a
  // public route); the {map} path parameter, if any, must be in its scope.
  absl::StatusOr<auth::Grant> Authorize(const httplib::Request& request, size_t i,
                                        const std::map<std::string, std::string>& path) const;
  void Dispatch(const httplib::Request& request, httplib::Response& response) const;
  static void Answer(RestReply reply, httplib::Response& response);
  // CORS headers; true for a preflight, answered here.
  bool ApplyCors(const httplib::Request& request, httplib::Response& response) const;
  bool OriginAllowed(const std::string& origin) const;
  // The methods of the routes whose template matches `path` ("GET, DELETE"); empty if none.
  std::string MethodsFor(const std::string& path) const;

  const Options options_;
  const std::vector<RestRoute> routes_;
  std::vector<CompiledRoute> compiled_;  // one per route
  std::optional<StaticFiles> files_;     // with web_root
  std::unique_ptr<httplib::Server> http_;
  std::thread listener_;
  int port_ = 0;
};

}  // namespace skimap::server

#endif  // SERVER_HTTP_HTTP_SERVER_H_
