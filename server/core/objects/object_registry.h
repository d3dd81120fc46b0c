// ObjectRegistry: the object service's state — the trained objects (models and the raw
// descriptors the forest trains on), the database's training parameters and the built
// classifier — kept in memory and persisted in one SQLite file (storage/object_store.h for
// the object database, storage/training_store.h for the raw descriptors).
//
//   auto registry = ObjectRegistry::Open({.db_path = data_dir + "/objects.sqlite"});
//   RETURN_IF_ERROR((*registry)->Add(std::move(trained), params));  // persisted
//   auto input = (*registry)->BeginBuild();  ... Build ...  (*registry)->FinishBuild(...)
//
// Rules: all objects share the training parameters (the first object fixes them); adding
// or deleting an object drops the classifier (it must be rebuilt); a build that finishes
// after the objects changed is discarded (Aborted).
//
// Persistence: each change is written before it becomes visible (raw descriptors first,
// then the object database in one transaction); Open reloads everything.
// Thread safety: thread safe. Mutations are serialized; readers never wait for SQLite.
#ifndef SERVER_CORE_OBJECTS_OBJECT_REGISTRY_H_
#define SERVER_CORE_OBJECTS_OBJECT_REGISTRY_H_

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "base/rw_lock.h"
#include "perception/objects/object_database.h"
#include "perception/objects/object_trainer.h"
#include "storage/object_store.h"
#include "storage/training_store.h"

namespace skimap::server {

class ObjectRegistry {
 public:
  struct Options {
    std::string db_path;  // SQLite file (created if missing); "" = in memory only
  };
  // Opens (creating or migrating) the file and loads the objects and the classifier.
  // DataLoss / FailedPrecondition for a corrupt or newer file.
  static absl::StatusOr<std::unique_ptr<ObjectRegistry>> Open(const Options& options);

  struct ObjectView {
    std::shared_ptr<const objects::TrainedObject> object;  // raw empty if not stored
    bool in_classifier = false;
  };
  struct BuildInput {
    objects::ObjectDatabaseParams params;  // the database's (classifier fields to override)
    std::vector<std::shared_ptr<const objects::TrainedObject>> objects;  // stack order
    uint64_t generation = 0;
  };

  // The database's resolved parameters; nullopt while it holds no object.
  std::optional<objects::ObjectDatabaseParams> params() const;
  // AlreadyExists if obj_id is trained.
  absl::Status CheckNew(int obj_id) const;
  // Adds and persists a trained object made with `params` (resolved). AlreadyExists;
  // FailedPrecondition if params differ from the database's descriptor-shaping ones.
  absl::Status Add(objects::TrainedObject object, const objects::ObjectDatabaseParams& params);
  // Deletes and persists; NotFound if absent.
  absl::Status Delete(int obj_id);
  // Every object, by obj_id.
  std::vector<ObjectView> List() const;
  // NotFound if absent.
  absl::StatusOr<ObjectView> Get(int obj_id) const;

  // Starts a build: FailedPrecondition without objects, while another build runs, or if
  // an object's raw descriptors were lost. Exactly one FinishBuild must follow.
  absl::StatusOr<BuildInput> BeginBuild();
  // Ends the build started by BeginBuild. With an OK result: installs and persists the
  // classifier (and its parameters), unless the objects changed since BeginBuild
  // (Aborted). Returns the build's error otherwise.
  absl::Status FinishBuild(const BuildInput& input, absl::StatusOr<objects::ObjectDatabase> db);
  bool building() const;
  // The built classifier; null when not built.
  std::shared_ptr<const objects::ObjectDatabase> classifier() const;

 private:
  ObjectRegistry() = default;
  absl::Status Load();
  // Writes the object database made of `objects` (+ the classifier's forest if given).
  absl::Status SaveDatabase(
      const objects::ObjectDatabaseParams& params,
      const std::vector<std::shared_ptr<const objects::TrainedObject>>& objects,
      const objects::ObjectDatabase* classifier);

  std::unique_ptr<storage::ObjectStore> store_;       // null: in memory only
  std::unique_ptr<storage::TrainingStore> training_;  // null: in memory only
  std::mutex write_mu_;                               // serializes mutations and their persistence
  mutable RwLock mu_;
  std::optional<objects::ObjectDatabaseParams> params_ ABSL_GUARDED_BY(mu_);
  std::vector<std::shared_ptr<const objects::TrainedObject>> objects_ ABSL_GUARDED_BY(mu_);
  std::shared_ptr<const objects::ObjectDatabase> classifier_ ABSL_GUARDED_BY(mu_);
  uint64_t generation_ ABSL_GUARDED_BY(mu_) = 0;  // bumped by every Add / Delete
  bool building_ ABSL_GUARDED_BY(mu_) = false;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_OBJECTS_OBJECT_REGISTRY_H_
