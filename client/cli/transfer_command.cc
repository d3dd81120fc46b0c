#include "client/cli/transfer_command.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "absl/strings/str_cat.h"

namespace skimap::client {
namespace {

constexpr size_t kPieceBytes = size_t{1} << 20;

}  // namespace

absl::StatusOr<uint64_t> ExportMapToFile(MapClient& client, const std::string& map_id,
                                         const std::string& path, bool with_journal) {
  const std::string part = path + ".part";
  uint64_t bytes = 0;
  absl::Status s;
  {
    std::ofstream out(part, std::ios::binary | std::ios::trunc);
    if (!out) return absl::UnavailableError(absl::StrCat("cannot write ", part));
    v1::ExportMapRequest request;
    request.set_name("maps/" + map_id);
    request.set_with_journal(with_journal);
    s = client.ExportMap(request, [&](std::string_view piece) {
      out.write(piece.data(), static_cast<std::streamsize>(piece.size()));
      if (!out) return absl::UnavailableError(absl::StrCat("cannot write ", part));
      bytes += piece.size();
      return absl::OkStatus();
    });
    out.close();
    if (s.ok() && !out) s = absl::UnavailableError(absl::StrCat("cannot write ", part));
  }
  std::error_code ec;
  if (s.ok()) {
    std::filesystem::rename(part, path, ec);
    if (ec) s = absl::UnavailableError(absl::StrCat("cannot rename ", part, ": ", ec.message()));
  }
  if (!s.ok()) {
    std::filesystem::remove(part, ec);
    return s;
  }
  return bytes;
}

absl::StatusOr<v1::Map> ImportMapFromFile(MapClient& client, const std::string& path,
                                          const std::string& as_id) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open ", path));
  return client.ImportMap(as_id, [&]() -> absl::StatusOr<std::string> {
    std::string piece(kPieceBytes, '\0');
    in.read(piece.data(), static_cast<std::streamsize>(piece.size()));
    if (in.bad()) return absl::UnavailableError(absl::StrCat("cannot read ", path));
    piece.resize(static_cast<size_t>(in.gcount()));
    return piece;
  });
}

}  // namespace skimap::client
