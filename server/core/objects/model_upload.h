// The files of one AddObjectModel stream, written into a private folder of their own under
// the server's scratch folder, and removed with this object.
//
//   absl::StatusOr<std::unique_ptr<ModelUpload>> u = ModelUpload::Create(scratch, limits);
//   (*u)->Add(piece);              // per ModelFile piece
//   (*u)->Has("cereal.obj");
//
// Names are client text: relative paths of letters, digits and ._- components (none "."
// or ".."), at most 4 folders deep and 200 characters; anything else is refused
// (InvalidArgument naming `file.name`), as are more than max_files files or max_bytes
// bytes in all (InvalidArgument naming the limit).
//
// Thread safety: not thread safe (one stream's messages arrive one at a time).
#ifndef SERVER_CORE_OBJECTS_MODEL_UPLOAD_H_
#define SERVER_CORE_OBJECTS_MODEL_UPLOAD_H_

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::server {

class ModelUpload {
 public:
  struct Limits {
    size_t max_files = 64;
    uint64_t max_bytes = uint64_t{256} << 20;
  };
  // A new empty folder under `scratch` (created if missing). Internal on I/O errors.
  static absl::StatusOr<std::unique_ptr<ModelUpload>> Create(const std::string& scratch,
                                                             const Limits& limits);
  ~ModelUpload();  // removes the folder
  ModelUpload(const ModelUpload&) = delete;
  ModelUpload& operator=(const ModelUpload&) = delete;

  // Appends a piece to its file.
  absl::Status Add(const v1::ModelFile& piece);
  // Closes the files (the upload is complete); InvalidArgument naming `model` unless a
  // file of that name was uploaded.
  absl::Status Seal(const std::string& model);

  const std::filesystem::path& dir() const { return dir_; }

 private:
  ModelUpload(std::filesystem::path dir, const Limits& limits)
      : dir_(std::move(dir)), limits_(limits) {}

  const std::filesystem::path dir_;
  const Limits limits_;
  std::map<std::string, std::ofstream> files_;
  uint64_t bytes_ = 0;
};

// InvalidArgument naming `field` unless `name` is a safe relative file name (see above).
absl::Status CheckModelFileName(const std::string& name, const std::string& field);

}  // namespace skimap::server

#endif  // SERVER_CORE_OBJECTS_MODEL_UPLOAD_H_
