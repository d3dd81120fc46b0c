// `skimap export` and `skimap import`: a map to and from an export file (docs/formats.md,
// "Export file"), through the ExportMap / ImportMap calls: the server never opens a path
// the client names.
//
//   skimap export --map=ID -o FILE [--with-journal]
//   skimap import FILE [--as=ID]
//
// Export writes FILE.part as the pieces arrive and renames it to FILE once the whole file
// is there, so FILE is never a partial export. Import reads FILE in pieces of 1 MiB.
//
// Thread safety: one call at a time per file (the client itself is shared).
#ifndef CLIENT_CLI_TRANSFER_COMMAND_H_
#define CLIENT_CLI_TRANSFER_COMMAND_H_

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "client/map_client.h"

namespace skimap::client {

// Exports map `map_id` into `path`; returns the file's size in bytes. Errors: the call's
// (NotFound, FailedPrecondition, ...), Unavailable for a file that cannot be written.
absl::StatusOr<uint64_t> ExportMapToFile(MapClient& client, const std::string& map_id,
                                         const std::string& path, bool with_journal);
// Imports the export file at `path` as map `as_id` ("" keeps the file's id). Errors: the
// call's (DataLoss, AlreadyExists, ...), NotFound / Unavailable for an unreadable file.
absl::StatusOr<v1::Map> ImportMapFromFile(MapClient& client, const std::string& path,
                                          const std::string& as_id);

}  // namespace skimap::client

#endif  // CLIENT_CLI_TRANSFER_COMMAND_H_
