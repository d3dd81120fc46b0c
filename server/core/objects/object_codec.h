// Conversions between the object API (skimap.v1 objects.proto) and the object pipeline
// (perception/objects): training frames, parameters, object summaries, resource names,
// and the raw-descriptor blobs kept by storage/training_store.h.
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_OBJECTS_OBJECT_CODEC_H_
#define SERVER_CORE_OBJECTS_OBJECT_CODEC_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "perception/objects/object_database.h"
#include "perception/objects/object_trainer.h"
#include "skimap/v1/objects.pb.h"

namespace skimap::server {

// obj_ids accepted by the API (BOP ids; the 06d folder names of train/).
inline constexpr int kMaxObjId = 999999;

// "objects/{obj_id}".
std::string ObjectName(int obj_id);
// Parses "objects/{obj_id}"; InvalidArgument naming `field` otherwise.
absl::StatusOr<int> ParseObjectName(absl::string_view name, absl::string_view field);
// InvalidArgument ("obj_id: ...") unless 1 <= obj_id <= kMaxObjId.
absl::Status CheckObjId(uint32_t obj_id);

// Applies the set fields of `api` on top of `base` (the database's params, or defaults)
// and resolves them (ResolveParams); InvalidArgument naming "params.<field>".
absl::StatusOr<objects::ObjectDatabaseParams> ApplyTrainingParams(
    const v1::TrainingParams& api, const objects::ObjectDatabaseParams& base);
absl::StatusOr<objects::ObjectDatabaseParams> ApplyClassifierParams(
    const v1::ClassifierParams& api, const objects::ObjectDatabaseParams& base);
// OK if `trained` (an object's resolved params) can join a database with `db` params:
// the descriptor-shaping fields must be equal. FailedPrecondition naming the field.
absl::Status CheckSameTraining(const objects::ObjectDatabaseParams& trained,
                               const objects::ObjectDatabaseParams& db);
v1::TrainingParams ToApiTrainingParams(const objects::ObjectDatabaseParams& p);
v1::ClassifierParams ToApiClassifierParams(const objects::ObjectDatabaseParams& p);

// Decodes and validates one training frame; InvalidArgument naming the field ("depth",
// "color", "mask", "intrinsics.fx", "object_pose.rotation", ...).
absl::StatusOr<objects::TrainingFrame> DecodeTrainingFrame(const v1::TrainingFrame& frame);
// Decodes a mask (MaskEncoding) of width x height; InvalidArgument naming `field`.
absl::StatusOr<cv::Mat> DecodeMask(v1::MaskEncoding encoding, const std::string& bytes, int width,
                                   int height, absl::string_view field);

// The BASIC view of an object (FULL adds the RGB volume; `resolution` is the database's).
v1::Object ToApiObject(const objects::ObjectModel& model, const objects::ObjectDatabaseParams& p,
                       bool in_classifier);
absl::Status AddRgbVoxels(const objects::ObjectModel& model, double resolution, v1::Object* out);

// One blob per voxel (DescriptorMatrix encoding) and back (DataLoss on a corrupt blob or a
// layout other than `layout`).
std::vector<std::string> EncodeRawDescriptors(const std::vector<objects::DescriptorMatrix>& raw);
absl::StatusOr<std::vector<objects::DescriptorMatrix>> DecodeRawDescriptors(
    const std::vector<std::string>& blobs, const objects::DescriptorLayout& layout);

}  // namespace skimap::server

#endif  // SERVER_CORE_OBJECTS_OBJECT_CODEC_H_
