// Fuzz target: the object database loader (server/core/objects/object_database_io.h:
// FromStoredRecords, which also parses the training parameters and the forest blob and
// validates everything through ObjectDatabase::Create), on records as the SQLite store
// hands them over.
//
// Input (FuzzInput): u8 flags (bit 0: the object_db row repeats the parameters' detector,
// resolution and classes per object; bit 1: recompute the forest blob's CRC), u8 format
// version, u8 count of parameter overrides, each u8 key index + bytes (the other
// parameters keep their defaults), bytes detector, u8 descriptor kind, u16 dims, u8 object
// count (at most 8), each: u32 obj_id, bytes name, bytes RGB volume, u8 voxel count, each:
// i16 x y z, u32 evidence, u8 centroid count, each: u32 cardinality, bytes descriptor;
// then u8 forest trees, u32 forest classes, bytes forest blob. A database that loads must
// classify a descriptor without crashing.
#include <cstdint>
#include <string>
#include <vector>

#include "perception/objects/features.h"
#include "server/core/objects/object_database_io.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const uint8_t flags = in.U8();
  storage::StoredObjectDatabase r;
  r.format_version = in.U8();
  r.params = objects::ParamsToText(objects::ObjectDatabaseParams{});
  std::vector<std::string> keys;
  for (const auto& [key, value] : r.params) keys.push_back(key);
  for (int n = in.U8() % 8; n > 0; --n) {
    const std::string& key = keys[in.U8() % keys.size()];
    r.params[key] = std::string(in.Bytes());
  }
  r.detector = std::string(in.Bytes());
  r.descriptor_kind = in.U8();
  r.descriptor_dims = in.U16();
  if (flags & 1) {
    if (auto p = objects::ParamsFromText(r.params); p.ok()) {
      r.detector = p->features.detector;
      r.resolution = p->resolution;
      r.classes_per_object = p->classes_per_object;
    }
  }
  for (int o = in.U8() % 9; o > 0; --o) {
    storage::StoredObject so;
    so.obj_id = static_cast<int>(in.U32());
    so.name = std::string(in.Bytes());
    so.rgb_volume = std::string(in.Bytes());
    for (int v = in.U8(); v > 0; --v) {
      storage::StoredVoxel sv;
      sv.kx = static_cast<int16_t>(in.U16());
      sv.ky = static_cast<int16_t>(in.U16());
      sv.kz = static_cast<int16_t>(in.U16());
      sv.evidence = in.U32();
      for (int c = in.U8(); c > 0; --c) {
        const uint32_t cardinality = in.U32();
        sv.centroids.push_back({cardinality, std::string(in.Bytes())});
      }
      so.voxels.push_back(std::move(sv));
    }
    r.objects.push_back(std::move(so));
  }
  r.forest_trees = in.U8();
  r.forest_classes = in.U32();
  r.forest = std::string(in.Bytes());
  if (flags & 2) FixTrailingCrc(&r.forest);

  absl::StatusOr<objects::ObjectDatabase> db = objects::FromStoredRecords(r);
  if (!db.ok()) {
    if (db.status().message().empty()) Fail("an error without a message");
    return 0;
  }
  const objects::DescriptorLayout layout = db->layout();
  std::vector<uint8_t> bits(layout.binary() ? layout.dims / 8 : 0, 0x5a);
  std::vector<float> values(layout.binary() ? 0 : layout.dims, 0.25f);
  std::vector<float> features;
  std::vector<objects::Prediction> predictions;
  db->Classify({.bits = bits.data(), .values = values.data()}, &features, &predictions);
  return 0;
}
