#include "server/core/objects/dataset_root.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace skimap::server {

namespace fs = std::filesystem;

absl::StatusOr<fs::path> ResolveUnderRoot(const std::string& root, const std::string& client_path,
                                          const char* field) {
  std::error_code ec;
  const fs::path base = fs::canonical(root, ec);
  if (ec) {
    return absl::FailedPreconditionError(
        absl::StrCat(field, ": the server's dataset root is not readable"));
  }
  fs::path p(client_path);
  if (p.is_relative()) p = base / p;
  const fs::path resolved = fs::weakly_canonical(p, ec);
  if (ec) return absl::PermissionDeniedError(absl::StrCat(field, ": not under the dataset root"));
  // Component by component: "/data/sets2" is not under "/data/sets".
  const auto [in_base, in_path] =
      std::mismatch(base.begin(), base.end(), resolved.begin(), resolved.end());
  if (in_base != base.end()) {
    return absl::PermissionDeniedError(absl::StrCat(field, ": not under the dataset root"));
  }
  return resolved;
}

}  // namespace skimap::server
