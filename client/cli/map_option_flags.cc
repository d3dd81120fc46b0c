#include "client/cli/map_option_flags.h"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/text_format.h"

// Strings, empty when not given: only the flags given are sent.
ABSL_FLAG(std::string, min_depth, "", "maps create / stream / eval: depth kept from, metres (0.1)");
ABSL_FLAG(std::string, max_depth, "", "maps create / stream / eval: depth kept up to, metres (5)");
ABSL_FLAG(std::string, min_voxel_weight, "",
          "maps create / stream / eval: queries ignore voxels lighter than this (1)");
ABSL_FLAG(std::string, band_min_z, "",
          "maps create / stream / eval: the occupancy grid's robot band, world z from, m (0.05)");
ABSL_FLAG(std::string, band_max_z, "", "maps create / stream / eval: ... to, m (1.5)");
ABSL_FLAG(std::string, floor_min_z, "",
          "maps create / stream / eval: the floor band, world z from, m, to band_min_z (-0.3)");
ABSL_FLAG(std::string, pixel_stride, "",
          "maps create / stream / eval: integrate every n-th pixel in rows and columns (1)");
ABSL_FLAG(std::string, carve_free_space, "",
          "maps create / stream / eval: free space from the rays, true or false (true)");
ABSL_FLAG(std::string, depth_edge_jump, "",
          "maps create / stream / eval: drop flying pixels, a depth jump to a neighbour above "
          "this fraction of the depth, 0..1; 0 keeps all (0.05)");
ABSL_FLAG(std::string, carve_pixel_stride, "",
          "maps create / stream / eval: carve along every n-th pixel's ray, 1..64 (4)");

namespace skimap::client {
namespace {

// Parses flag `name`'s value with `parse` and hands it to `set` (nothing when the flag is
// empty: not given); InvalidArgument naming the flag when it does not parse.
template <class T, class ParseFn>
absl::Status Parse(const absl::Flag<std::string>& flag, const char* name, const char* what,
                   ParseFn&& parse, const std::function<void(T)>& set) {
  const std::string text = absl::GetFlag(flag);
  if (text.empty()) return absl::OkStatus();
  T value;
  if (!parse(text, &value)) {
    return absl::InvalidArgumentError(absl::StrCat("--", name, ": not ", what, ": \"", text, "\""));
  }
  set(value);
  return absl::OkStatus();
}

}  // namespace

absl::Status ApplyMapOptionFlags(v1::MapOptions* o) {
  auto number = [](absl::string_view t, double* v) { return absl::SimpleAtod(t, v); };
  // Counts outside uint32 are clamped (a negative one to 0), so the server answers with
  // its range message.
  auto count = [](absl::string_view t, int64_t* v) { return absl::SimpleAtoi(t, v); };
  auto boolean = [](absl::string_view t, bool* v) { return absl::SimpleAtob(t, v); };
  auto as_u32 = [](int64_t v) {
    return uint32_t(std::clamp<int64_t>(v, 0, std::numeric_limits<uint32_t>::max()));
  };
  for (absl::Status s : {
           Parse<double>(FLAGS_min_depth, "min_depth", "a number", number,
                         [&](double v) { o->set_min_depth(v); }),
           Parse<double>(FLAGS_max_depth, "max_depth", "a number", number,
                         [&](double v) { o->set_max_depth(v); }),
           Parse<double>(FLAGS_min_voxel_weight, "min_voxel_weight", "a number", number,
                         [&](double v) { o->set_min_voxel_weight(float(v)); }),
           Parse<double>(FLAGS_band_min_z, "band_min_z", "a number", number,
                         [&](double v) { o->set_band_min_z(v); }),
           Parse<double>(FLAGS_band_max_z, "band_max_z", "a number", number,
                         [&](double v) { o->set_band_max_z(v); }),
           Parse<double>(FLAGS_floor_min_z, "floor_min_z", "a number", number,
                         [&](double v) { o->set_floor_min_z(v); }),
           Parse<int64_t>(FLAGS_pixel_stride, "pixel_stride", "an integer", count,
                          [&](int64_t v) { o->set_pixel_stride(as_u32(v)); }),
           Parse<bool>(FLAGS_carve_free_space, "carve_free_space", "true or false", boolean,
                       [&](bool v) { o->set_carve_free_space(v); }),
           Parse<double>(FLAGS_depth_edge_jump, "depth_edge_jump", "a number", number,
                         [&](double v) { o->set_depth_edge_jump(v); }),
           Parse<int64_t>(FLAGS_carve_pixel_stride, "carve_pixel_stride", "an integer", count,
                          [&](int64_t v) { o->set_carve_pixel_stride(as_u32(v)); }),
       }) {
    if (!s.ok()) return s;
  }
  return absl::OkStatus();
}

absl::Status CheckMapOptions(const v1::MapOptions& given, const v1::MapOptions& existing,
                             const std::string& map_name) {
  const google::protobuf::Reflection* r = given.GetReflection();
  std::vector<const google::protobuf::FieldDescriptor*> fields;
  r->ListFields(given, &fields);
  for (const google::protobuf::FieldDescriptor* f : fields) {
    if (f->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE) continue;
    std::string mine, theirs;
    google::protobuf::TextFormat::PrintFieldValueToString(given, f, -1, &mine);
    google::protobuf::TextFormat::PrintFieldValueToString(existing, f, -1, &theirs);
    if (mine != theirs) {
      return absl::FailedPreconditionError(absl::StrCat(
          map_name, " exists with ", f->name(), " ", theirs, "; --", f->name(), "=", mine,
          " applies only to a map the command creates (delete the map or drop the flag)"));
    }
  }
  return absl::OkStatus();
}

}  // namespace skimap::client
