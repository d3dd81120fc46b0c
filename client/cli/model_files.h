// The files a 3D model needs beside itself, for `skimap objects add MODEL --on_server`,
// which uploads them: an OBJ's MTL files (mtllib) and the images they name (map_*), a
// glTF's buffers and images (uri, not data: URIs); PLY and GLB are one file. Names are
// relative to the model's folder; a file outside it, or missing, is left out and reported
// in `skipped` (the model then renders without it, as Assimp would).
//
// Thread safety: reentrant.
#ifndef CLIENT_CLI_MODEL_FILES_H_
#define CLIENT_CLI_MODEL_FILES_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/object_client.h"

namespace skimap::client {

struct ModelFileSet {
  std::vector<ObjectClient::ModelFileToSend> files;  // the model first
  std::vector<std::string> skipped;                  // named by the model, not sent
};

// NotFound when `model` is not a file.
absl::StatusOr<ModelFileSet> ModelFiles(const std::string& model);

}  // namespace skimap::client

#endif  // CLIENT_CLI_MODEL_FILES_H_
