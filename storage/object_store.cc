#include "storage/object_store.h"

#include <ctime>

#include "absl/strings/str_cat.h"
#include "storage/schema.h"
#include "storage/status_macros.h"

namespace skimap::storage {

absl::StatusOr<std::unique_ptr<ObjectStore>> ObjectStore::Open(const std::string& path) {
  absl::StatusOr<std::unique_ptr<Database>> db = Database::Open(path);
  if (!db.ok()) return db.status();
  SK_RETURN_IF_ERROR(Migrate(**db, StorageMigrations()));
  return std::unique_ptr<ObjectStore>(new ObjectStore(*std::move(db)));
}

absl::Status ObjectStore::Save(const StoredObjectDatabase& db) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  SK_RETURN_IF_ERROR(tx.status());
  SK_RETURN_IF_ERROR(SaveLocked(db));
  return tx.Commit();
}

absl::Status ObjectStore::SaveLocked(const StoredObjectDatabase& db) {
  SK_RETURN_IF_ERROR(db_->Exec(
      "DELETE FROM forest; DELETE FROM centroids; DELETE FROM voxels; DELETE FROM objects;"
      "DELETE FROM training_params; DELETE FROM object_db;"));
  SK_ASSIGN_OR_RETURN(
      head,
      db_->Prepare(
          "INSERT INTO object_db(id, format_version, detector, descriptor_kind, descriptor_dims,"
          " resolution, classes_per_object, saved_unix_s) VALUES (1, ?, ?, ?, ?, ?, ?, ?)"));
  SK_RETURN_IF_ERROR(head.BindInt(1, db.format_version));
  SK_RETURN_IF_ERROR(head.BindText(2, db.detector));
  SK_RETURN_IF_ERROR(head.BindInt(3, db.descriptor_kind));
  SK_RETURN_IF_ERROR(head.BindInt(4, db.descriptor_dims));
  SK_RETURN_IF_ERROR(head.BindDouble(5, db.resolution));
  SK_RETURN_IF_ERROR(head.BindInt(6, db.classes_per_object));
  SK_RETURN_IF_ERROR(head.BindInt(7, static_cast<int64_t>(std::time(nullptr))));
  SK_RETURN_IF_ERROR(head.Run());

  SK_ASSIGN_OR_RETURN(param, db_->Prepare("INSERT INTO training_params(key, value) VALUES (?, ?)"));
  for (const auto& [key, value] : db.params) {
    param.Reset();
    SK_RETURN_IF_ERROR(param.BindText(1, key));
    SK_RETURN_IF_ERROR(param.BindText(2, value));
    SK_RETURN_IF_ERROR(param.Run());
  }

  SK_ASSIGN_OR_RETURN(
      obj,
      db_->Prepare(
          "INSERT INTO objects(obj_id, stack_index, name, frames, features, descriptors,"
          " raw_descriptor_bytes, centroid_bytes, rgb_volume) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)"));
  SK_ASSIGN_OR_RETURN(
      vox, db_->Prepare(
               "INSERT INTO voxels(obj_id, rank, kx, ky, kz, evidence) VALUES (?, ?, ?, ?, ?, ?)"));
  SK_ASSIGN_OR_RETURN(cen, db_->Prepare("INSERT INTO centroids(obj_id, rank, idx, cardinality, "
                                        "descriptor) VALUES (?, ?, ?, ?, ?)"));
  for (size_t i = 0; i < db.objects.size(); ++i) {
    const StoredObject& o = db.objects[i];
    obj.Reset();
    SK_RETURN_IF_ERROR(obj.BindInt(1, o.obj_id));
    SK_RETURN_IF_ERROR(obj.BindInt(2, static_cast<int64_t>(i)));
    SK_RETURN_IF_ERROR(obj.BindText(3, o.name));
    SK_RETURN_IF_ERROR(obj.BindInt(4, o.frames));
    SK_RETURN_IF_ERROR(obj.BindInt(5, o.features));
    SK_RETURN_IF_ERROR(obj.BindInt(6, o.descriptors));
    SK_RETURN_IF_ERROR(obj.BindInt(7, o.raw_descriptor_bytes));
    SK_RETURN_IF_ERROR(obj.BindInt(8, o.centroid_bytes));
    SK_RETURN_IF_ERROR(obj.BindBlob(9, o.rgb_volume));
    SK_RETURN_IF_ERROR(obj.Run());
    for (size_t r = 0; r < o.voxels.size(); ++r) {
      const StoredVoxel& v = o.voxels[r];
      vox.Reset();
      SK_RETURN_IF_ERROR(vox.BindInt(1, o.obj_id));
      SK_RETURN_IF_ERROR(vox.BindInt(2, static_cast<int64_t>(r)));
      SK_RETURN_IF_ERROR(vox.BindInt(3, v.kx));
      SK_RETURN_IF_ERROR(vox.BindInt(4, v.ky));
      SK_RETURN_IF_ERROR(vox.BindInt(5, v.kz));
      SK_RETURN_IF_ERROR(vox.BindInt(6, v.evidence));
      SK_RETURN_IF_ERROR(vox.Run());
      for (size_t c = 0; c < v.centroids.size(); ++c) {
        cen.Reset();
        SK_RETURN_IF_ERROR(cen.BindInt(1, o.obj_id));
        SK_RETURN_IF_ERROR(cen.BindInt(2, static_cast<int64_t>(r)));
        SK_RETURN_IF_ERROR(cen.BindInt(3, static_cast<int64_t>(c)));
        SK_RETURN_IF_ERROR(cen.BindInt(4, v.centroids[c].cardinality));
        SK_RETURN_IF_ERROR(cen.BindBlob(5, v.centroids[c].descriptor));
        SK_RETURN_IF_ERROR(cen.Run());
      }
    }
  }
  if (!db.forest.empty()) {
    SK_ASSIGN_OR_RETURN(
        f,
        db_->Prepare(
            "INSERT INTO forest(id, trees, max_depth, num_classes, model) VALUES (1, ?, ?, ?, ?)"));
    SK_RETURN_IF_ERROR(f.BindInt(1, db.forest_trees));
    SK_RETURN_IF_ERROR(f.BindInt(2, db.forest_max_depth));
    SK_RETURN_IF_ERROR(f.BindInt(3, db.forest_classes));
    SK_RETURN_IF_ERROR(f.BindBlob(4, db.forest));
    SK_RETURN_IF_ERROR(f.Run());
  }
  return absl::OkStatus();
}

absl::StatusOr<StoredObjectDatabase> ObjectStore::Load() {
  std::lock_guard<std::mutex> lock(mu_);
  // A read transaction: one consistent snapshot of all tables.
  SK_RETURN_IF_ERROR(db_->Exec("BEGIN;"));
  absl::StatusOr<StoredObjectDatabase> out = LoadLocked();
  (void)db_->Exec("COMMIT;");
  return out;
}

absl::StatusOr<StoredObjectDatabase> ObjectStore::LoadLocked() {
  StoredObjectDatabase db;
  SK_ASSIGN_OR_RETURN(
      head,
      db_->Prepare("SELECT format_version, detector, descriptor_kind, descriptor_dims, resolution,"
                   " classes_per_object FROM object_db WHERE id = 1"));
  SK_ASSIGN_OR_RETURN(has_head, head.Step());
  if (!has_head)
    return absl::NotFoundError(absl::StrCat(db_->path(), ": no object database saved"));
  db.format_version = static_cast<int>(head.ColumnInt(0));
  db.detector = head.ColumnText(1);
  db.descriptor_kind = static_cast<int>(head.ColumnInt(2));
  db.descriptor_dims = static_cast<int>(head.ColumnInt(3));
  db.resolution = head.ColumnDouble(4);
  db.classes_per_object = static_cast<int>(head.ColumnInt(5));

  SK_ASSIGN_OR_RETURN(param, db_->Prepare("SELECT key, value FROM training_params"));
  for (;;) {
    SK_ASSIGN_OR_RETURN(row, param.Step());
    if (!row) break;
    db.params[param.ColumnText(0)] = param.ColumnText(1);
  }

  SK_ASSIGN_OR_RETURN(
      obj, db_->Prepare("SELECT obj_id, name, frames, features, descriptors, raw_descriptor_bytes,"
                        " centroid_bytes, rgb_volume FROM objects ORDER BY stack_index"));
  std::map<int, size_t> index;
  for (;;) {
    SK_ASSIGN_OR_RETURN(row, obj.Step());
    if (!row) break;
    StoredObject o;
    o.obj_id = static_cast<int>(obj.ColumnInt(0));
    o.name = obj.ColumnText(1);
    o.frames = obj.ColumnInt(2);
    o.features = obj.ColumnInt(3);
    o.descriptors = obj.ColumnInt(4);
    o.raw_descriptor_bytes = obj.ColumnInt(5);
    o.centroid_bytes = obj.ColumnInt(6);
    o.rgb_volume = obj.ColumnBlob(7);
    index[o.obj_id] = db.objects.size();
    db.objects.push_back(std::move(o));
  }
  SK_ASSIGN_OR_RETURN(
      vox,
      db_->Prepare("SELECT obj_id, rank, kx, ky, kz, evidence FROM voxels ORDER BY obj_id, rank"));
  for (;;) {
    SK_ASSIGN_OR_RETURN(row, vox.Step());
    if (!row) break;
    StoredObject& o = db.objects[index.at(static_cast<int>(vox.ColumnInt(0)))];
    if (vox.ColumnInt(1) != static_cast<int64_t>(o.voxels.size())) {
      return absl::DataLossError(absl::StrCat("voxels: object ", o.obj_id, " has a rank gap"));
    }
    o.voxels.push_back({static_cast<int32_t>(vox.ColumnInt(2)),
                        static_cast<int32_t>(vox.ColumnInt(3)),
                        static_cast<int32_t>(vox.ColumnInt(4)),
                        static_cast<uint32_t>(vox.ColumnInt(5)),
                        {}});
  }
  SK_ASSIGN_OR_RETURN(cen, db_->Prepare("SELECT obj_id, rank, idx, cardinality, descriptor FROM "
                                        "centroids ORDER BY obj_id, rank, idx"));
  for (;;) {
    SK_ASSIGN_OR_RETURN(row, cen.Step());
    if (!row) break;
    StoredObject& o = db.objects[index.at(static_cast<int>(cen.ColumnInt(0)))];
    StoredVoxel& v = o.voxels.at(static_cast<size_t>(cen.ColumnInt(1)));
    if (cen.ColumnInt(2) != static_cast<int64_t>(v.centroids.size())) {
      return absl::DataLossError(absl::StrCat("centroids: object ", o.obj_id, " has an index gap"));
    }
    v.centroids.push_back({static_cast<uint32_t>(cen.ColumnInt(3)), cen.ColumnBlob(4)});
  }
  SK_ASSIGN_OR_RETURN(
      f, db_->Prepare("SELECT trees, max_depth, num_classes, model FROM forest WHERE id = 1"));
  SK_ASSIGN_OR_RETURN(has_forest, f.Step());
  if (has_forest) {
    db.forest_trees = static_cast<int>(f.ColumnInt(0));
    db.forest_max_depth = static_cast<int>(f.ColumnInt(1));
    db.forest_classes = f.ColumnInt(2);
    db.forest = f.ColumnBlob(3);
  }
  return db;
}

absl::StatusOr<std::vector<StoredObjectSummary>> ObjectStore::ListObjects() {
  std::lock_guard<std::mutex> lock(mu_);
  SK_ASSIGN_OR_RETURN(st,
                      db_->Prepare("SELECT o.obj_id, o.name, o.descriptors,"
                                   " (SELECT COUNT(*) FROM voxels v WHERE v.obj_id = o.obj_id),"
                                   " (SELECT COUNT(*) FROM centroids c WHERE c.obj_id = o.obj_id)"
                                   " FROM objects o ORDER BY o.stack_index"));
  std::vector<StoredObjectSummary> out;
  for (;;) {
    SK_ASSIGN_OR_RETURN(row, st.Step());
    if (!row) break;
    out.push_back({static_cast<int>(st.ColumnInt(0)), st.ColumnText(1), st.ColumnInt(3),
                   st.ColumnInt(4), st.ColumnInt(2)});
  }
  return out;
}

absl::Status ObjectStore::DeleteObject(int obj_id) {
  std::lock_guard<std::mutex> lock(mu_);
  Transaction tx(*db_);
  SK_RETURN_IF_ERROR(tx.status());
  SK_ASSIGN_OR_RETURN(st, db_->Prepare("DELETE FROM objects WHERE obj_id = ?"));
  SK_RETURN_IF_ERROR(st.BindInt(1, obj_id));
  SK_RETURN_IF_ERROR(st.Run());
  SK_ASSIGN_OR_RETURN(changes, db_->Prepare("SELECT changes()"));
  SK_ASSIGN_OR_RETURN(row, changes.Step());
  if (!row || changes.ColumnInt(0) == 0) {
    return absl::NotFoundError(absl::StrCat("obj_id: ", obj_id, " not in the object database"));
  }
  SK_RETURN_IF_ERROR(db_->Exec("DELETE FROM forest;"));
  return tx.Commit();
}

}  // namespace skimap::storage
