#include "server/core/objects/object_service.h"

#include <algorithm>
#include <map>
#include <opencv2/imgproc.hpp>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "base/echo.h"
#include "codec/image_codec.h"
#include "perception/objects/training.h"
#include "server/core/common/page_token.h"
#include "server/core/objects/object_codec.h"

namespace skimap::server {

ObjectService::ObjectService(const Options& options)
    : options_(options),
      operations_({.max_finished = options.max_operations}),
      training_worker_({.capacity = 256}),
      job_worker_({.capacity = std::max<size_t>(1, options.max_queued_jobs)}) {}

ObjectService::~ObjectService() = default;

absl::StatusOr<std::unique_ptr<ObjectService>> ObjectService::Create(const Options& options) {
  if (options.threads < 1) {
    return absl::InvalidArgumentError(absl::StrCat("threads: ", options.threads, " must be >= 1"));
  }
  absl::StatusOr<std::unique_ptr<ObjectRegistry>> registry =
      ObjectRegistry::Open({.db_path = options.db_path});
  if (!registry.ok()) return registry.status();
  std::unique_ptr<ObjectService> s(new ObjectService(options));
  s->registry_ = *std::move(registry);
  return s;
}

absl::StatusOr<v1::ListObjectsResponse> ObjectService::ListObjects(
    const v1::ListObjectsRequest& request) const {
  if (request.page_size() < 0 || request.page_size() > 1000) {
    return absl::InvalidArgumentError(
        absl::StrCat("page_size: ", request.page_size(), " must be in 0..1000"));
  }
  const uint32_t query = QueryFingerprint(0, "ListObjects", "");
  int after = 0;
  if (!request.page_token().empty()) {
    absl::StatusOr<std::string> position = DecodePageToken(request.page_token(), query);
    if (!position.ok()) return position.status();
    if (!absl::SimpleAtoi(*position, &after)) {
      return absl::InvalidArgumentError("page_token: not a ListObjects position");
    }
  }
  const size_t limit = request.page_size() == 0 ? 100 : static_cast<size_t>(request.page_size());
  const std::optional<objects::ObjectDatabaseParams> params = registry_->params();
  v1::ListObjectsResponse out;
  for (const ObjectRegistry::ObjectView& v : registry_->List()) {
    const objects::ObjectModel& m = v.object->model;
    if (m.obj_id <= after || !params) continue;  // !params: every object was just deleted
    if (static_cast<size_t>(out.objects_size()) == limit) {
      out.set_next_page_token(
          EncodePageToken(query, absl::StrCat(out.objects(out.objects_size() - 1).obj_id())));
      break;
    }
    *out.add_objects() = ToApiObject(m, *params, v.in_classifier);
  }
  return out;
}

absl::StatusOr<v1::Object> ObjectService::GetObject(const v1::GetObjectRequest& request) const {
  absl::StatusOr<int> id = ParseObjectName(request.name(), "name");
  if (!id.ok()) return id.status();
  absl::StatusOr<ObjectRegistry::ObjectView> v = registry_->Get(*id);
  if (!v.ok()) return v.status();
  const std::optional<objects::ObjectDatabaseParams> params = registry_->params();
  if (!params)
    return absl::NotFoundError(absl::StrCat("object ", Echo(request.name()), " not found"));
  v1::Object out = ToApiObject(v->object->model, *params, v->in_classifier);
  if (request.view() == v1::OBJECT_VIEW_FULL) {
    if (absl::Status s = AddRgbVoxels(v->object->model, params->resolution, &out); !s.ok()) {
      return s;
    }
  }
  return out;
}

absl::Status ObjectService::DeleteObject(const v1::DeleteObjectRequest& request) {
  absl::StatusOr<int> id = ParseObjectName(request.name(), "name");
  if (!id.ok()) return id.status();
  return registry_->Delete(*id);
}

absl::StatusOr<v1::Operation> ObjectService::BuildClassifier(
    const v1::BuildClassifierRequest& request) {
  // Validate the parameters before anything starts.
  std::optional<objects::ObjectDatabaseParams> base = registry_->params();
  if (base) {
    absl::StatusOr<objects::ObjectDatabaseParams> p =
        ApplyClassifierParams(request.params(), *base);
    if (!p.ok()) return p.status();
  }
  absl::StatusOr<ObjectRegistry::BuildInput> input = registry_->BeginBuild();
  if (!input.ok()) return input.status();
  const std::string op = operations_.Start("BuildClassifier");
  const bool queued =
      job_worker_.TrySubmit([this, op, api = request.params(), in = *input]() mutable {
        RunBuild(op, api, std::move(in));
      });
  if (!queued) {
    const absl::Status full = absl::ResourceExhaustedError("jobs: queue full, retry later");
    (void)registry_->FinishBuild(*input, full);
    operations_.Finish(op, full, nullptr);
    return full;
  }
  return operations_.Get(op);
}

void ObjectService::RunBuild(const std::string& op, const v1::ClassifierParams& api,
                             ObjectRegistry::BuildInput input) {
  auto progress = [&](const std::string& stage, int64_t done, int64_t total, double fraction) {
    v1::OperationProgress p;
    p.set_stage(stage);
    p.set_done(done);
    p.set_total(total);
    p.set_fraction(fraction);
    operations_.SetProgress(op, p);
  };
  absl::StatusOr<objects::ObjectDatabase> db = [&]() -> absl::StatusOr<objects::ObjectDatabase> {
    absl::StatusOr<objects::ObjectDatabaseParams> params = ApplyClassifierParams(api, input.params);
    if (!params.ok()) return params.status();
    params->forest.threads = options_.threads;
    absl::StatusOr<std::unique_ptr<objects::ObjectDatabaseBuilder>> builder =
        objects::ObjectDatabaseBuilder::Create(*params);
    if (!builder.ok()) return builder.status();
    progress("stacking", 0, 1, 0.02);
    for (const auto& o : input.objects) {
      // The builder owns its objects; the registry keeps sharing the originals.
      if (absl::Status s = (*builder)->AddObject(*o); !s.ok()) return s;
    }
    return (*builder)->Build([&](const objects::BuildProgress& b) {
      progress(b.stage, b.done, b.total,
               0.05 + 0.9 * double(b.done) / std::max<int64_t>(1, b.total));
    });
  }();
  if (db.ok()) progress("saving", 0, 1, 0.96);
  const absl::Status status = registry_->FinishBuild(input, std::move(db));
  const v1::Classifier classifier = GetClassifier();
  operations_.Finish(op, status,
                     [&](v1::Operation* out) { *out->mutable_classifier() = classifier; });
}

v1::Classifier ObjectService::GetClassifier() const {
  v1::Classifier out;
  std::shared_ptr<const objects::ObjectDatabase> db = registry_->classifier();
  if (db == nullptr) {
    out.set_state(registry_->building() ? v1::Classifier::BUILDING : v1::Classifier::NOT_BUILT);
    if (std::optional<objects::ObjectDatabaseParams> p = registry_->params()) {
      *out.mutable_params() = ToApiClassifierParams(*p);
      out.set_detector(p->features.detector);
    }
    return out;
  }
  out.set_state(registry_->building() ? v1::Classifier::BUILDING : v1::Classifier::READY);
  for (const objects::ObjectModel& m : db->objects()) out.add_objects(ObjectName(m.obj_id));
  out.set_classes(db->stack().num_classes());
  *out.mutable_params() = ToApiClassifierParams(db->params());
  out.set_model_bytes(db->ModelBytes());
  out.set_detector(db->params().features.detector);
  return out;
}

absl::StatusOr<v1::ClassifyImageResponse> ObjectService::ClassifyImage(
    const v1::ClassifyImageRequest& request) const {
  const absl::Time start = absl::Now();
  std::shared_ptr<const objects::ObjectDatabase> db = registry_->classifier();
  if (db == nullptr) {
    return absl::FailedPreconditionError(
        "classifier: not built (BuildClassifier after training objects)");
  }
  perception::ColorCodec codec;
  switch (request.color_encoding()) {
    case v1::COLOR_ENCODING_RAW_RGB8:
      codec = perception::ColorCodec::kRawRgb8;
      break;
    case v1::COLOR_ENCODING_PNG:
      codec = perception::ColorCodec::kPng;
      break;
    case v1::COLOR_ENCODING_JPEG:
      codec = perception::ColorCodec::kJpeg;
      break;
    default:
      return absl::InvalidArgumentError("color_encoding: must be RAW_RGB8, PNG or JPEG");
  }
  const int w = static_cast<int>(request.width()), h = static_cast<int>(request.height());
  absl::StatusOr<perception::ColorImage> color =
      perception::DecodeColor(codec, request.color(), w, h);
  if (!color.ok()) return color.status();
  cv::Mat bgr;
  cv::cvtColor(cv::Mat(h, w, CV_8UC3, color->rgb.data()), bgr, cv::COLOR_RGB2BGR);
  cv::Mat mask;
  if (request.mask_encoding() != v1::MASK_ENCODING_UNSPECIFIED || !request.mask().empty()) {
    absl::StatusOr<cv::Mat> m = DecodeMask(request.mask_encoding(), request.mask(), w, h, "mask");
    if (!m.ok()) return m.status();
    mask = *std::move(m);
  }
  absl::StatusOr<std::unique_ptr<objects::FeatureExtractor>> extractor =
      objects::FeatureExtractor::Create(db->params().features);
  if (!extractor.ok()) return extractor.status();
  absl::StatusOr<objects::Features> features = (*extractor)->Extract(bgr, mask);
  if (!features.ok()) return features.status();
  std::map<int, uint64_t> votes;
  std::vector<float> scratch;
  v1::ClassifyImageResponse out;
  out.set_features(features->descriptors.rows());
  for (size_t i = 0; i < features->descriptors.rows(); ++i) {
    objects::Prediction p;
    if (db->Recognize(features->descriptors.Row(i), &scratch, &p)) {
      ++votes[p.obj_id];
      out.set_verified(out.verified() + 1);
      if (request.return_matches()) {
        v1::FeatureMatch* m = out.add_matches();
        m->set_x(features->keypoints[i].pt.x);
        m->set_y(features->keypoints[i].pt.y);
        m->set_object(ObjectName(p.obj_id));
        m->set_obj_id(p.obj_id);
        m->mutable_model_point()->set_x(p.point.x());
        m->mutable_model_point()->set_y(p.point.y());
        m->mutable_model_point()->set_z(p.point.z());
        m->set_confidence(p.confidence);
      }
    }
  }
  std::vector<std::pair<int, uint64_t>> sorted(votes.begin(), votes.end());
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  for (const auto& [id, n] : sorted) {
    v1::ObjectVotes* v = out.add_objects();
    v->set_object(ObjectName(id));
    v->set_votes(n);
  }
  const absl::Duration t = absl::Now() - start;
  out.mutable_time()->set_seconds(absl::ToInt64Seconds(t));
  out.mutable_time()->set_nanos(
      static_cast<int32_t>(absl::ToInt64Nanoseconds(t % absl::Seconds(1))));
  return out;
}

absl::StatusOr<v1::Operation> ObjectService::GetOperation(
    const v1::GetOperationRequest& request) const {
  return operations_.Get(request.name());
}

void ObjectService::WaitOperation(const v1::WaitOperationRequest& request,
                                  OperationTable::WaitDone done) {
  absl::Duration timeout = absl::Seconds(10);
  if (request.has_timeout()) {
    timeout =
        absl::Seconds(request.timeout().seconds()) + absl::Nanoseconds(request.timeout().nanos());
    if (timeout < absl::ZeroDuration() || timeout > absl::Seconds(60)) {
      return done(absl::InvalidArgumentError("timeout: must be in [0, 60] seconds"));
    }
  }
  if (absl::StatusOr<v1::Operation> op = operations_.Get(request.name()); !op.ok()) {
    return done(op.status());
  }
  operations_.Wait(request.name(), timeout, std::move(done));
}

}  // namespace skimap::server
