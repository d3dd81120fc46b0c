#include "server/http/static_files.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "base/echo.h"

namespace skimap::server {
namespace fs = std::filesystem;

const char* MimeTypeOf(absl::string_view file_name) {
  static const std::pair<const char*, const char*> kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "application/javascript; charset=utf-8"},
      {".mjs", "application/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".ico", "image/x-icon"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".txt", "text/plain; charset=utf-8"},
      {".woff2", "font/woff2"},
      {".woff", "font/woff"},
      {".wasm", "application/wasm"},
  };
  const std::string lower = absl::AsciiStrToLower(file_name);
  for (const auto& [extension, type] : kTypes) {
    if (absl::EndsWith(lower, extension)) return type;
  }
  return "application/octet-stream";
}

absl::StatusOr<StaticFiles> StaticFiles::Open(const std::string& root) {
  std::error_code error;
  const fs::path real = fs::canonical(root, error);
  if (error || !fs::is_regular_file(real / "index.html", error)) {
    return absl::NotFoundError(absl::StrCat("--web_root ", root,
                                            ": not a directory with an index.html (build the "
                                            "viewer: cd web && npm ci && npm run build)"));
  }
  return StaticFiles(real.string());
}

absl::StatusOr<RestReply> StaticFiles::Get(absl::string_view path) const {
  const absl::Status missing = absl::NotFoundError(absl::StrCat("no file ", Echo(path)));
  if (path.empty() || path.front() != '/') return missing;
  std::string relative(path.substr(1));
  if (relative.empty()) relative = "index.html";
  if (absl::StrContains(relative, '\\') || absl::StrContains(relative, '\0')) return missing;
  for (absl::string_view segment : absl::StrSplit(relative, '/')) {
    if (segment.empty() || segment.front() == '.') return missing;  // "..", ".", ".git"
  }
  std::error_code error;
  const fs::path real = fs::canonical(fs::path(root_) / relative, error);
  if (error || !absl::StartsWith(real.string(), root_ + "/") || !fs::is_regular_file(real, error)) {
    return missing;
  }
  std::ifstream in(real, std::ios::binary);
  if (!in) return missing;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  RestReply reply{.content_type = MimeTypeOf(real.filename().string()), .body = bytes.str()};
  reply.headers.emplace_back("Cache-Control", absl::StartsWith(relative, "assets/")
                                                  ? "public, max-age=31536000, immutable"
                                                  : "no-cache");
  reply.headers.emplace_back("X-Content-Type-Options", "nosniff");
  return reply;
}

}  // namespace skimap::server
