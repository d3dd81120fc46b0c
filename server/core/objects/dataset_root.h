// ResolveUnderRoot: a client-named path confined to a directory the operator configured.
//
//   absl::StatusOr<std::filesystem::path> dir = ResolveUnderRoot("/srv/datasets", "ycbv/train");
//
// The client's path is taken relative to `root` (an absolute one must lie under it too),
// made canonical (".." and symbolic links resolved, as far as the path exists), and
// refused with PermissionDenied unless it is `root` or lies below it. Messages never echo
// the client's path: it may name something outside the root, and saying whether that
// exists would let a client probe the server's file system.
//
// Thread safety: pure function (reads the file system).
#ifndef SERVER_CORE_OBJECTS_DATASET_ROOT_H_
#define SERVER_CORE_OBJECTS_DATASET_ROOT_H_

#include <filesystem>
#include <string>

#include "absl/status/statusor.h"

namespace skimap::server {

// `field` names the request field in messages ("dataset_path").
// REQUIRES: root is not empty.
absl::StatusOr<std::filesystem::path> ResolveUnderRoot(const std::string& root,
                                                       const std::string& client_path,
                                                       const char* field);

}  // namespace skimap::server

#endif  // SERVER_CORE_OBJECTS_DATASET_ROOT_H_
