#include "server/core/maps/query_box.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/core/common/page_token.h"

namespace skimap::server {

absl::StatusOr<KeyBox> QueryKeyBox(const Grid& grid, bool has_box, const v1::Box3& b) {
  KeyBox keys;
  if (!has_box) return keys;
  const double lo[3] = {b.min().x(), b.min().y(), b.min().z()};
  const double hi[3] = {b.max().x(), b.max().y(), b.max().z()};
  const double origin[3] = {grid.origin().x, grid.origin().y, grid.origin().z};
  int32_t* mins[3] = {&keys.min.x, &keys.min.y, &keys.min.z};
  int32_t* maxs[3] = {&keys.max.x, &keys.max.y, &keys.max.z};
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(lo[a]) || !std::isfinite(hi[a]) || lo[a] > hi[a]) {
      return absl::InvalidArgumentError("box must be finite with min <= max");
    }
    grid.CenterRange(lo[a], hi[a], origin[a], mins[a], maxs[a]);
  }
  return keys;
}

void EncodeQueryBox(bool has_box, const v1::Box3& b, Encoder& e) {
  e.U8(has_box);
  for (double v : {b.min().x(), b.min().y(), b.min().z(), b.max().x(), b.max().y(), b.max().z()}) {
    e.F64(v);
  }
}

absl::StatusOr<std::optional<uint64_t>> DecodeKeyPageToken(const std::string& token, uint32_t query,
                                                           absl::string_view rpc) {
  if (token.empty()) return std::nullopt;
  absl::StatusOr<std::string> position = DecodePageToken(token, query);
  if (!position.ok()) return position.status();
  Decoder d(*position);
  uint64_t packed = 0;
  if (!d.U64(&packed) || d.remaining() != 0 || packed >= (uint64_t{1} << (3 * kKeyBits))) {
    return absl::InvalidArgumentError(absl::StrCat("page_token: not a ", rpc, " position"));
  }
  return packed;
}

std::string KeyPageToken(uint32_t query, uint64_t packed) {
  std::string position;
  Encoder(&position).U64(packed);
  return EncodePageToken(query, position);
}

}  // namespace skimap::server
