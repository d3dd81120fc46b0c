// Fuzz target: the SkiMap volume file reader (skimap/serialization.h), for every voxel type.
//
// Input: u8 control (low bits: voxel type, voxel_types.h; bit 7: recompute the trailing
// CRC first, so mutations reach the body), then the file. A file that loads must write
// back to a file that loads to the same file again (serialization is canonical after one
// round), with the voxel count it claims.
#include <cstdint>
#include <string>

#include "skimap/serialization.h"
#include "tests/fuzz/fuzz_input.h"
#include "tests/fuzz/voxel_types.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const uint8_t control = in.U8();
  std::string file(in.Rest());
  if (control & 0x80) FixTrailingCrc(&file);
  VisitVoxelType(control & 0x7f, [&](auto voxel) {
    using V = decltype(voxel);
    auto map = DeserializeMap<V>(file, {});
    if (!map.ok()) {
      if (map.status().message().empty()) Fail("an error without a message");
      return;
    }
    const std::string once = SerializeMap(**map);
    auto again = DeserializeMap<V>(once, {});
    if (!again.ok()) Fail("a loaded map does not load after writing it");
    if (SerializeMap(**again) != once) Fail("writing a map is not canonical");
  });
  return 0;
}
