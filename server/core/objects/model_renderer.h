// Runs skimap-model-views (sim/model_views_main.cc) on an uploaded model: a process of its
// own, in the upload's folder, so that a model file that crashes, hangs or eats memory in
// the model reader fails this one call and nothing else. The child limits its own CPU time
// and address space; this side kills it past `timeout`.
//
//   absl::Status s = RenderModelViews({.binary = path}, upload_dir, "cereal.obj", views,
//                                     /*obj_id=*/7, "views");   // -> upload_dir/views/
//
// Errors: InvalidArgument naming `model` (the renderer's own one-line message, or "the
// model renderer died on it (signal N)" / "took over N s"), Internal when it cannot run.
//
// Thread safety: reentrant.
#ifndef SERVER_CORE_OBJECTS_MODEL_RENDERER_H_
#define SERVER_CORE_OBJECTS_MODEL_RENDERER_H_

#include <string>

#include "absl/status/status.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::server {

struct ModelRendererOptions {
  std::string binary;  // path of skimap-model-views
  int timeout_seconds = 600;
  int max_memory_mb = 4096;
};

// InvalidArgument naming views.* unless `views` is a valid ModelViews.
absl::Status CheckModelViews(const v1::ModelViews& views);

absl::Status RenderModelViews(const ModelRendererOptions& options, const std::string& dir,
                              const std::string& model, const v1::ModelViews& views, int obj_id,
                              const std::string& out);

}  // namespace skimap::server

#endif  // SERVER_CORE_OBJECTS_MODEL_RENDERER_H_
