// Helpers of the object service tests: an in-process skimapd endpoint on a data dir, and
// the sim `mini` training views streamed through the client library.
#ifndef TESTS_SERVER_OBJECTS_OBJECT_SERVICE_FIXTURE_H_
#define TESTS_SERVER_OBJECTS_OBJECT_SERVICE_FIXTURE_H_

#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/training_frames.h"
#include "client/object_client.h"
#include "dataset/reader.h"
#include "server/app/server.h"
#include "tests/perception/objects/sim_data.h"

namespace skimap::testing {

// A Server on 127.0.0.1:<free port> (gRPC only) whose object database is DATA_DIR/objects.sqlite.
inline std::unique_ptr<server::Server> StartServer(const std::string& data_dir) {
  server::Server::Options o;
  o.grpc.address = "127.0.0.1:0";
  o.maps.worker_threads = 1;
  o.objects.db_path = data_dir + "/objects.sqlite";
  o.objects.threads = 2;
  // TrainObjectFromDataset reads the generated test datasets only.
  o.objects.dataset_root = SKIMAP_OBJECTS_TEST_DATA_DIR;
  absl::StatusOr<std::unique_ptr<server::Server>> s = server::Server::Start(o);
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? *std::move(s) : nullptr;
}

inline std::unique_ptr<client::ObjectClient> Connect(const server::Server& s) {
  return client::ObjectClient::Connect(absl::StrCat("127.0.0.1:", s.grpc_port()));
}

// Training views of obj_id (every `stride`-th of the training frames of sim_data.h).
inline std::vector<v1::TrainingFrame> MiniViews(int obj_id, int stride) {
  const std::string scene =
      absl::StrFormat("%s/train/%06d", objects::testing::MiniDataset(), obj_id);
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(scene);
  EXPECT_TRUE(seq.ok()) << seq.status();
  std::vector<v1::TrainingFrame> out;
  if (!seq.ok()) return out;
  int kept = 0;
  for (const dataset::Frame& f : seq->frames) {
    if (!objects::testing::TrainView(obj_id, f.id)) continue;
    if (kept++ % stride != 0) continue;
    absl::StatusOr<std::optional<v1::TrainingFrame>> v = client::ToTrainingFrame(f, obj_id);
    EXPECT_TRUE(v.ok()) << v.status();
    if (v.ok() && v->has_value()) out.push_back(**v);
  }
  return out;
}

// The held-out views of obj_id as ClassifyImage requests (colour + visible mask).
inline std::vector<v1::ClassifyImageRequest> HeldOutImages(int obj_id) {
  const std::string scene =
      absl::StrFormat("%s/train/%06d", objects::testing::MiniDataset(), obj_id);
  absl::StatusOr<dataset::Sequence> seq = dataset::LoadBopScene(scene);
  EXPECT_TRUE(seq.ok()) << seq.status();
  std::vector<v1::ClassifyImageRequest> out;
  if (!seq.ok()) return out;
  for (const dataset::Frame& f : seq->frames) {
    if (!objects::testing::HeldOutView(obj_id, f.id)) continue;
    absl::StatusOr<std::optional<v1::TrainingFrame>> v = client::ToTrainingFrame(f, obj_id);
    if (!v.ok() || !v->has_value()) continue;
    v1::ClassifyImageRequest& r = out.emplace_back();
    r.set_color_encoding((*v)->color_encoding());
    r.set_color((*v)->color());
    r.set_width((*v)->intrinsics().width());
    r.set_height((*v)->intrinsics().height());
    r.set_mask_encoding((*v)->mask_encoding());
    r.set_mask((*v)->mask());
  }
  return out;
}

// Streams `views` as object obj_id. ORB unless said: the fastest detector (these tests are
// about the service; ObjectCodecTest checks that the default is SIFT).
inline absl::StatusOr<v1::Object> Train(client::ObjectClient& c, int obj_id,
                                        const std::vector<v1::TrainingFrame>& views,
                                        const std::string& detector = "ORB") {
  v1::TrainObjectRequest header;
  header.set_obj_id(obj_id);
  header.set_display_name(absl::StrCat("object ", obj_id));
  header.mutable_params()->set_detector(detector);
  size_t next = 0;
  return c.TrainObject(header, [&]() -> absl::StatusOr<std::optional<v1::TrainingFrame>> {
    if (next == views.size()) return std::optional<v1::TrainingFrame>();
    return std::optional<v1::TrainingFrame>(views[next++]);
  });
}

}  // namespace skimap::testing

#endif  // TESTS_SERVER_OBJECTS_OBJECT_SERVICE_FIXTURE_H_
