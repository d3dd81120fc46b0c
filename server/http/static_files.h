// StaticFiles: the files of the browser viewer (web/dist, docs/viewer.md) as HTTP replies.
// GET / answers index.html; other paths name files under the root. Each reply carries its
// MIME type from the extension (text/html, application/javascript, text/css,
// image/svg+xml, image/png, application/json, font/woff2, ...; else
// application/octet-stream) and a Cache-Control header: files under /assets/ are named by
// their content hash (vite), so they are `public, max-age=31536000, immutable`; every other
// file (index.html) is `no-cache` (revalidated, so a new build is picked up at once).
//
// Never a file outside the root: a path with a `..`, `.`, empty or hidden (".x") segment, a
// backslash or a NUL is refused (NotFound, as a missing file: nothing is revealed), and the
// file's real path (symlinks resolved) must lie under the root's real path.
//
//   absl::StatusOr<StaticFiles> files = StaticFiles::Open("/srv/skimap/web");
//   absl::StatusOr<RestReply> reply = files->Get("/assets/index-3f2a.js");
//
// Thread safety: immutable after Open; Get may be called concurrently.
#ifndef SERVER_HTTP_STATIC_FILES_H_
#define SERVER_HTTP_STATIC_FILES_H_

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/http/rest_route.h"

namespace skimap::server {

class StaticFiles {
 public:
  // `root` must be a directory holding index.html; NotFound otherwise (naming it).
  static absl::StatusOr<StaticFiles> Open(const std::string& root);

  // The file at URL path `path` (decoded, starting with '/'). NotFound if there is no
  // such file or the path is refused (above).
  absl::StatusOr<RestReply> Get(absl::string_view path) const;

  const std::string& root() const { return root_; }

 private:
  explicit StaticFiles(std::string root) : root_(std::move(root)) {}
  std::string root_;  // real path, without a trailing '/'
};

// The MIME type of a file name by its extension ("application/octet-stream" if unknown).
const char* MimeTypeOf(absl::string_view file_name);

}  // namespace skimap::server

#endif  // SERVER_HTTP_STATIC_FILES_H_
