// A model upload's private folder. See model_upload.h for the contract.
#include "server/core/objects/model_upload.h"

#include <atomic>
#include <chrono>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "base/echo.h"

namespace skimap::server {
namespace fs = std::filesystem;

absl::Status CheckModelFileName(const std::string& name, const std::string& field) {
  auto refuse = [&](const char* why) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", Echo(name), " ", why));
  };
  if (name.empty()) return absl::InvalidArgumentError(absl::StrCat(field, ": required"));
  if (name.size() > 200) return refuse("is over 200 characters");
  int parts = 0;
  for (absl::string_view part : absl::StrSplit(name, '/')) {
    if (++parts > 5) return refuse("is more than 4 folders deep");
    if (part.empty() || part == "." || part == "..") {
      return refuse("is not a relative path of plain names (no /, ., .. or empty parts)");
    }
    for (char c : part) {
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) {
        return refuse("may hold only letters, digits, '.', '_', '-' and '/'");
      }
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<ModelUpload>> ModelUpload::Create(const std::string& scratch,
                                                                 const Limits& limits) {
  static std::atomic<uint64_t> counter{0};
  std::error_code ec;
  fs::create_directories(scratch, ec);
  const uint64_t stamp =
      static_cast<uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
  const fs::path dir =
      fs::path(scratch) / absl::StrCat("upload-", stamp, "-", counter.fetch_add(1));
  if (ec || !fs::create_directory(dir, ec) || ec) {
    return absl::InternalError(
        absl::StrCat("model upload: cannot create a folder under the "
                     "server's scratch folder: ",
                     ec.message()));
  }
  return std::unique_ptr<ModelUpload>(new ModelUpload(dir, limits));
}

ModelUpload::~ModelUpload() {
  files_.clear();
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

absl::Status ModelUpload::Add(const v1::ModelFile& piece) {
  if (absl::Status s = CheckModelFileName(piece.name(), "file.name"); !s.ok()) return s;
  if (bytes_ + piece.data().size() > limits_.max_bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("file.data: a model upload holds at most ", limits_.max_bytes >> 20, " MiB"));
  }
  auto it = files_.find(piece.name());
  if (it == files_.end()) {
    if (files_.size() >= limits_.max_files) {
      return absl::InvalidArgumentError(
          absl::StrCat("file.name: a model upload holds at most ", limits_.max_files, " files"));
    }
    const fs::path path = dir_ / piece.name();
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (ec || !out || fs::is_directory(path, ec)) {
      return absl::InvalidArgumentError(
          absl::StrCat("file.name: ", Echo(piece.name()), " cannot be a file of this upload"));
    }
    it = files_.emplace(piece.name(), std::move(out)).first;
  }
  it->second.write(piece.data().data(), static_cast<std::streamsize>(piece.data().size()));
  if (!it->second) {
    return absl::InternalError("model upload: cannot write to the server's scratch folder");
  }
  bytes_ += piece.data().size();
  return absl::OkStatus();
}

absl::Status ModelUpload::Seal(const std::string& model) {
  for (auto& [name, out] : files_) out.close();
  if (files_.count(model) == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("model: ", Echo(model), " is not among the files sent"));
  }
  return absl::OkStatus();
}

}  // namespace skimap::server
