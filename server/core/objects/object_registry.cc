#include "server/core/objects/object_registry.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "server/core/objects/object_codec.h"
#include "server/core/objects/object_database_io.h"

namespace skimap::server {
namespace {

using objects::ObjectDatabase;
using objects::TrainedObject;
using ObjectPtr = std::shared_ptr<const TrainedObject>;

}  // namespace

absl::StatusOr<std::unique_ptr<ObjectRegistry>> ObjectRegistry::Open(const Options& options) {
  std::unique_ptr<ObjectRegistry> r(new ObjectRegistry());
  if (options.db_path.empty()) return r;
  absl::StatusOr<std::unique_ptr<storage::ObjectStore>> store =
      storage::ObjectStore::Open(options.db_path);
  if (!store.ok()) return store.status();
  r->store_ = *std::move(store);
  absl::StatusOr<std::unique_ptr<storage::TrainingStore>> training =
      storage::TrainingStore::Open(options.db_path);
  if (!training.ok()) return training.status();
  r->training_ = *std::move(training);
  if (absl::Status s = r->Load(); !s.ok()) {
    return absl::Status(s.code(), absl::StrCat(options.db_path, ": ", s.message()));
  }
  return r;
}

absl::Status ObjectRegistry::Load() {
  absl::StatusOr<storage::StoredObjectDatabase> records = store_->Load();
  if (absl::IsNotFound(records.status())) return training_->DeleteAllExcept({});
  if (!records.ok()) return records.status();
  if (records->objects.empty()) return training_->DeleteAllExcept({});
  absl::StatusOr<ObjectDatabase> db = objects::FromStoredRecords(*records);
  if (!db.ok()) return db.status();
  std::vector<ObjectPtr> loaded;
  std::vector<int> ids;
  for (const objects::ObjectModel& model : db->objects()) {
    auto t = std::make_shared<TrainedObject>();
    t->model = model;
    absl::StatusOr<std::vector<std::string>> blobs = training_->Get(model.obj_id);
    if (blobs.ok()) {
      absl::StatusOr<std::vector<objects::DescriptorMatrix>> raw =
          DecodeRawDescriptors(*blobs, db->layout());
      if (!raw.ok()) return raw.status();
      if (raw->size() == model.voxels.size()) t->raw = *std::move(raw);
    } else if (!absl::IsNotFound(blobs.status())) {
      return blobs.status();
    }
    ids.push_back(model.obj_id);
    loaded.push_back(std::move(t));
  }
  if (absl::Status s = training_->DeleteAllExcept(ids); !s.ok()) return s;
  WriterLock lock(&mu_);
  params_ = db->params();
  objects_ = std::move(loaded);
  if (db->forest().num_trees() > 0) {
    classifier_ = std::make_shared<const ObjectDatabase>(*std::move(db));
  }
  return absl::OkStatus();
}

std::optional<objects::ObjectDatabaseParams> ObjectRegistry::params() const {
  ReaderLock lock(&mu_);
  return params_;
}

absl::Status ObjectRegistry::CheckNew(int obj_id) const {
  ReaderLock lock(&mu_);
  for (const ObjectPtr& o : objects_) {
    if (o->model.obj_id == obj_id) {
      return absl::AlreadyExistsError(
          absl::StrCat("obj_id: ", ObjectName(obj_id), " is already trained (delete it first)"));
    }
  }
  return absl::OkStatus();
}

absl::Status ObjectRegistry::SaveDatabase(const objects::ObjectDatabaseParams& params,
                                          const std::vector<ObjectPtr>& objects,
                                          const ObjectDatabase* classifier) {
  if (store_ == nullptr) return absl::OkStatus();
  if (classifier != nullptr) return store_->Save(objects::ToStoredRecords(*classifier));
  std::vector<objects::ObjectModel> models;
  for (const ObjectPtr& o : objects) models.push_back(o->model);
  absl::StatusOr<ObjectDatabase> db =
      ObjectDatabase::Create(params, std::move(models), objects::RandomForest());
  if (!db.ok()) return db.status();
  return store_->Save(objects::ToStoredRecords(*db));
}

absl::Status ObjectRegistry::Add(TrainedObject object,
                                 const objects::ObjectDatabaseParams& params) {
  std::lock_guard<std::mutex> write(write_mu_);
  if (absl::Status s = CheckNew(object.model.obj_id); !s.ok()) return s;
  std::optional<objects::ObjectDatabaseParams> db_params = this->params();
  if (db_params) {
    if (absl::Status s = CheckSameTraining(params, *db_params); !s.ok()) return s;
  } else {
    db_params = params;
  }
  std::vector<ObjectPtr> next;
  {
    ReaderLock lock(&mu_);
    next = objects_;
  }
  const int obj_id = object.model.obj_id;
  if (training_ != nullptr) {
    if (absl::Status s = training_->Put(obj_id, EncodeRawDescriptors(object.raw)); !s.ok()) {
      return s;
    }
  }
  next.push_back(std::make_shared<const TrainedObject>(std::move(object)));
  if (absl::Status s = SaveDatabase(*db_params, next, nullptr); !s.ok()) {
    if (training_ != nullptr) (void)training_->Delete(obj_id);
    return s;
  }
  WriterLock lock(&mu_);
  params_ = db_params;
  objects_ = std::move(next);
  classifier_.reset();
  ++generation_;
  return absl::OkStatus();
}

absl::Status ObjectRegistry::Delete(int obj_id) {
  std::lock_guard<std::mutex> write(write_mu_);
  std::vector<ObjectPtr> next;
  {
    ReaderLock lock(&mu_);
    next = objects_;
  }
  auto it = std::find_if(next.begin(), next.end(),
                         [&](const ObjectPtr& o) { return o->model.obj_id == obj_id; });
  if (it == next.end()) {
    return absl::NotFoundError(absl::StrCat("object ", ObjectName(obj_id), " not found"));
  }
  next.erase(it);
  if (store_ != nullptr) {
    // Cascades to voxels and centroids and drops the forest (its classes no longer match).
    if (absl::Status s = store_->DeleteObject(obj_id); !s.ok()) return s;
    if (absl::Status s = training_->Delete(obj_id); !s.ok()) return s;
  }
  WriterLock lock(&mu_);
  objects_ = std::move(next);
  if (objects_.empty()) params_.reset();
  classifier_.reset();
  ++generation_;
  return absl::OkStatus();
}

std::vector<ObjectRegistry::ObjectView> ObjectRegistry::List() const {
  std::vector<ObjectView> out;
  {
    ReaderLock lock(&mu_);
    for (const ObjectPtr& o : objects_) out.push_back({o, classifier_ != nullptr});
  }
  std::sort(out.begin(), out.end(), [](const ObjectView& a, const ObjectView& b) {
    return a.object->model.obj_id < b.object->model.obj_id;
  });
  return out;
}

absl::StatusOr<ObjectRegistry::ObjectView> ObjectRegistry::Get(int obj_id) const {
  ReaderLock lock(&mu_);
  for (const ObjectPtr& o : objects_) {
    if (o->model.obj_id == obj_id) return ObjectView{o, classifier_ != nullptr};
  }
  return absl::NotFoundError(absl::StrCat("object ", ObjectName(obj_id), " not found"));
}

absl::StatusOr<ObjectRegistry::BuildInput> ObjectRegistry::BeginBuild() {
  WriterLock lock(&mu_);
  if (building_) {
    return absl::FailedPreconditionError("classifier: a build is already running");
  }
  if (objects_.empty()) {
    return absl::FailedPreconditionError("classifier: no objects to build it from (train some)");
  }
  for (const ObjectPtr& o : objects_) {
    if (o->raw.size() != o->model.voxels.size()) {
      return absl::FailedPreconditionError(
          absl::StrCat("classifier: ", ObjectName(o->model.obj_id),
                       " has no stored training descriptors; delete and train it again"));
    }
  }
  building_ = true;
  return BuildInput{*params_, objects_, generation_};
}

absl::Status ObjectRegistry::FinishBuild(const BuildInput& input,
                                         absl::StatusOr<ObjectDatabase> db) {
  std::lock_guard<std::mutex> write(write_mu_);
  absl::Status status = db.status();
  bool current = false;
  {
    ReaderLock lock(&mu_);
    current = generation_ == input.generation;
  }
  if (status.ok() && !current) {
    status = absl::AbortedError("classifier: objects changed during the build; build again");
  }
  std::shared_ptr<const ObjectDatabase> built;
  if (status.ok()) {
    built = std::make_shared<const ObjectDatabase>(*std::move(db));
    // Mutations hold write_mu_, so the objects cannot change before the swap below.
    status = SaveDatabase(built->params(), input.objects, built.get());
  }
  WriterLock lock(&mu_);
  building_ = false;
  if (!status.ok()) return status;
  classifier_ = std::move(built);
  params_ = classifier_->params();
  return absl::OkStatus();
}

bool ObjectRegistry::building() const {
  ReaderLock lock(&mu_);
  return building_;
}

std::shared_ptr<const ObjectDatabase> ObjectRegistry::classifier() const {
  ReaderLock lock(&mu_);
  return classifier_;
}

}  // namespace skimap::server
