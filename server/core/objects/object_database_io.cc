#include "server/core/objects/object_database_io.h"

#include <cstdio>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace skimap::objects {
namespace {

constexpr int kRecordsFormatVersion = 1;

std::string D(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

// Reads one text parameter into an int / int64 / double / string field.
class ParamReader {
 public:
  explicit ParamReader(const std::map<std::string, std::string>& t) : t_(t) {}
  template <class T>
  void Get(const std::string& key, T* out) {
    if (!status_.ok()) return;
    auto it = t_.find(key);
    bool ok = it != t_.end();
    if (ok) {
      if constexpr (std::is_same_v<T, std::string>) {
        *out = it->second;
      } else if constexpr (std::is_same_v<T, double>) {
        ok = absl::SimpleAtod(it->second, out);
      } else {
        ok = absl::SimpleAtoi(it->second, out);
      }
    }
    if (!ok)
      status_ = absl::InvalidArgumentError(
          absl::StrCat("training_params: ", key, " missing or malformed"));
  }
  const absl::Status& status() const { return status_; }

 private:
  const std::map<std::string, std::string>& t_;
  absl::Status status_;
};

std::string DescriptorBlob(const DescriptorLayout& l, DescriptorRef d) {
  std::string out;
  Encoder e(&out);
  if (l.binary()) {
    e.Bytes(std::string_view(reinterpret_cast<const char*>(d.bits), l.dims / 8));
  } else {
    for (int i = 0; i < l.dims; ++i) e.F32(d.values[i]);
  }
  return out;
}

}  // namespace

std::map<std::string, std::string> ParamsToText(const ObjectDatabaseParams& p) {
  return {{"detector", p.features.detector},
          {"max_features", absl::StrCat(p.features.max_features)},
          {"resolution", D(p.resolution)},
          {"bandwidth", D(p.mean_shift.bandwidth)},
          {"kernel", absl::StrCat(static_cast<int>(p.mean_shift.kernel))},
          {"max_iterations", absl::StrCat(p.mean_shift.max_iterations)},
          {"max_seeds", absl::StrCat(p.mean_shift.max_seeds)},
          {"classes_per_object", absl::StrCat(p.classes_per_object)},
          {"trees", absl::StrCat(p.forest.trees)},
          {"max_depth", absl::StrCat(p.forest.max_depth)},
          {"min_samples_split", absl::StrCat(p.forest.min_samples_split)},
          {"features_per_split", absl::StrCat(p.forest.features_per_split)},
          {"thresholds_per_feature", absl::StrCat(p.forest.thresholds_per_feature)},
          {"bootstrap_fraction", D(p.forest.bootstrap_fraction)},
          {"leaf_classes", absl::StrCat(p.forest.leaf_classes)},
          {"seed", absl::StrCat(p.forest.seed)},
          {"threads", absl::StrCat(p.forest.threads)},
          {"max_samples_per_class", absl::StrCat(p.max_samples_per_class)},
          {"verify_threshold", D(p.verify_threshold)},
          {"top_n", absl::StrCat(p.top_n)},
          {"mask_erosion_px", absl::StrCat(p.mask_erosion_px)},
          {"rgb_stride_px", absl::StrCat(p.rgb_stride_px)},
          {"zoom_out", D(p.zoom_out)},
          {"min_instance_score", D(p.instances.min_score)},
          {"min_instance_fit", D(p.instances.min_fit)},
          {"max_view_conflict", D(p.instances.max_view_conflict)}};
}

absl::StatusOr<ObjectDatabaseParams> ParamsFromText(const std::map<std::string, std::string>& t) {
  ObjectDatabaseParams p;
  ParamReader r(t);
  int kernel = 0;
  r.Get("detector", &p.features.detector);
  r.Get("max_features", &p.features.max_features);
  r.Get("resolution", &p.resolution);
  r.Get("bandwidth", &p.mean_shift.bandwidth);
  r.Get("kernel", &kernel);
  r.Get("max_iterations", &p.mean_shift.max_iterations);
  r.Get("max_seeds", &p.mean_shift.max_seeds);
  r.Get("classes_per_object", &p.classes_per_object);
  r.Get("trees", &p.forest.trees);
  r.Get("max_depth", &p.forest.max_depth);
  r.Get("min_samples_split", &p.forest.min_samples_split);
  r.Get("features_per_split", &p.forest.features_per_split);
  r.Get("thresholds_per_feature", &p.forest.thresholds_per_feature);
  r.Get("bootstrap_fraction", &p.forest.bootstrap_fraction);
  r.Get("leaf_classes", &p.forest.leaf_classes);
  r.Get("seed", &p.forest.seed);
  r.Get("threads", &p.forest.threads);
  r.Get("max_samples_per_class", &p.max_samples_per_class);
  r.Get("verify_threshold", &p.verify_threshold);
  r.Get("top_n", &p.top_n);
  r.Get("mask_erosion_px", &p.mask_erosion_px);
  r.Get("rgb_stride_px", &p.rgb_stride_px);
  if (!r.status().ok()) return r.status();
  p.zoom_out = 1;  // databases written before zoom-outs have none
  if (t.contains("zoom_out")) r.Get("zoom_out", &p.zoom_out);
  // Databases written before instance thresholds were stored get their detector's.
  p.instances = DefaultInstanceThresholds(p.features.detector);
  if (t.contains("min_instance_score")) r.Get("min_instance_score", &p.instances.min_score);
  if (t.contains("min_instance_fit")) r.Get("min_instance_fit", &p.instances.min_fit);
  if (t.contains("max_view_conflict")) r.Get("max_view_conflict", &p.instances.max_view_conflict);
  if (!r.status().ok()) return r.status();
  p.mean_shift.kernel = static_cast<MeanShiftKernel>(kernel);
  return p;
}

storage::StoredObjectDatabase ToStoredRecords(const ObjectDatabase& db) {
  storage::StoredObjectDatabase r;
  r.format_version = kRecordsFormatVersion;
  r.detector = db.params().features.detector;
  r.descriptor_kind = static_cast<int>(db.layout().kind);
  r.descriptor_dims = db.layout().dims;
  r.resolution = db.params().resolution;
  r.classes_per_object = db.params().classes_per_object;
  r.params = ParamsToText(db.params());
  for (const ObjectModel& o : db.objects()) {
    storage::StoredObject so{.obj_id = o.obj_id,
                             .name = o.name,
                             .frames = o.stats.frames,
                             .features = o.stats.features,
                             .descriptors = o.stats.descriptors,
                             .raw_descriptor_bytes = o.stats.raw_descriptor_bytes,
                             .centroid_bytes = o.stats.centroid_bytes,
                             .rgb_volume = o.rgb_volume};
    for (const VoxelModel& v : o.voxels) {
      storage::StoredVoxel sv{v.key.x, v.key.y, v.key.z, v.evidence, {}};
      for (size_t c = 0; c < v.centroids.rows(); ++c) {
        sv.centroids.push_back(
            {v.cardinalities[c], DescriptorBlob(db.layout(), v.centroids.Row(c))});
      }
      so.voxels.push_back(std::move(sv));
    }
    r.objects.push_back(std::move(so));
  }
  if (db.forest().num_trees() > 0) {
    r.forest_trees = db.forest().num_trees();
    r.forest_max_depth = db.params().forest.max_depth;
    r.forest_classes = db.forest().num_classes();
    r.forest = db.forest().Serialize();
  }
  return r;
}

absl::StatusOr<ObjectDatabase> FromStoredRecords(const storage::StoredObjectDatabase& r) {
  if (r.format_version != kRecordsFormatVersion) {
    return absl::InvalidArgumentError(absl::StrCat("object_db: format_version ", r.format_version,
                                                   " unsupported (want ", kRecordsFormatVersion,
                                                   ")"));
  }
  absl::StatusOr<ObjectDatabaseParams> params = ParamsFromText(r.params);
  if (!params.ok()) return params.status();
  absl::StatusOr<DescriptorLayout> layout = DetectorLayout(params->features.detector);
  if (!layout.ok()) return layout.status();
  if (static_cast<int>(layout->kind) != r.descriptor_kind || layout->dims != r.descriptor_dims) {
    return absl::DataLossError("object_db: descriptor layout does not match the detector");
  }
  // The object_db row repeats three training parameters: a row that disagrees is corrupt.
  if (r.detector != params->features.detector || r.resolution != params->resolution ||
      r.classes_per_object != params->classes_per_object) {
    return absl::DataLossError(
        "object_db: detector, resolution or classes_per_object contradicts training_params");
  }
  std::vector<ObjectModel> objects;
  for (const storage::StoredObject& so : r.objects) {
    ObjectModel o;
    o.obj_id = so.obj_id;
    o.name = so.name;
    o.stats = {so.frames, so.features, so.descriptors, so.raw_descriptor_bytes, so.centroid_bytes};
    o.rgb_volume = so.rgb_volume;
    for (const storage::StoredVoxel& sv : so.voxels) {
      VoxelModel v;
      v.key = {sv.kx, sv.ky, sv.kz};
      v.evidence = sv.evidence;
      v.centroids = DescriptorMatrix(*layout);
      for (const storage::StoredCentroid& c : sv.centroids) {
        if (c.descriptor.size() != layout->RowBytes()) {
          return absl::DataLossError(absl::StrCat("centroids: object ", so.obj_id,
                                                  " has a descriptor of ", c.descriptor.size(),
                                                  " bytes, want ", layout->RowBytes()));
        }
        Decoder d(c.descriptor);
        if (layout->binary()) {
          v.centroids.AppendBits(reinterpret_cast<const uint8_t*>(c.descriptor.data()));
        } else {
          std::vector<float> values(layout->dims);
          for (float& x : values) (void)d.F32(&x);
          v.centroids.AppendValues(values.data());
        }
        v.cardinalities.push_back(c.cardinality);
      }
      o.voxels.push_back(std::move(v));
    }
    objects.push_back(std::move(o));
  }
  RandomForest forest;
  if (!r.forest.empty()) {
    absl::StatusOr<RandomForest> f = RandomForest::Deserialize(r.forest);
    if (!f.ok()) return f.status();
    if (f->num_trees() != r.forest_trees || f->num_classes() != r.forest_classes) {
      return absl::DataLossError("forest: trees or num_classes contradict the forest blob");
    }
    forest = *std::move(f);
  }
  return ObjectDatabase::Create(*std::move(params), std::move(objects), std::move(forest));
}

absl::Status SaveObjectDatabase(const ObjectDatabase& db, const std::string& path) {
  absl::StatusOr<std::unique_ptr<storage::ObjectStore>> store = storage::ObjectStore::Open(path);
  if (!store.ok()) return store.status();
  return (*store)->Save(ToStoredRecords(db));
}

absl::StatusOr<ObjectDatabase> LoadObjectDatabase(const std::string& path) {
  absl::StatusOr<std::unique_ptr<storage::ObjectStore>> store = storage::ObjectStore::Open(path);
  if (!store.ok()) return store.status();
  absl::StatusOr<storage::StoredObjectDatabase> records = (*store)->Load();
  if (!records.ok()) return records.status();
  return FromStoredRecords(*records);
}

}  // namespace skimap::objects
