// Fuzz target: the forest blob reader (perception/objects/random_forest.h Deserialize).
//
// Input: u8 flags (bit 0: recompute the trailing CRC first), then the blob. A forest that
// loads must predict (every index was validated, no tree walk may leave the model or loop),
// and serialize back to the same blob.
#include <cstdint>
#include <string>
#include <vector>

#include "perception/objects/random_forest.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const uint8_t flags = in.U8();
  std::string blob(in.Rest());
  if (flags & 1) FixTrailingCrc(&blob);
  absl::StatusOr<objects::RandomForest> f = objects::RandomForest::Deserialize(blob);
  if (!f.ok()) {
    if (f.status().message().empty()) Fail("an error without a message");
    return 0;
  }
  // A blob may encode a forest non-canonically (the fuzzer finds such blobs); its canonical
  // form must then load back to itself.
  const std::string canonical = f->Serialize();
  if (canonical != blob) {
    absl::StatusOr<objects::RandomForest> again = objects::RandomForest::Deserialize(canonical);
    if (!again.ok() || again->Serialize() != canonical) {
      Fail("a loaded forest's serialization does not load back to itself");
    }
  }
  if (f->dims() < 0) Fail("a forest with negative dims loaded");
  if (f->dims() > (1 << 16)) return 0;  // valid, but too wide to predict here
  std::vector<float> x(std::max(f->dims(), 1));
  std::vector<objects::ClassScore> scores;
  for (float v : {-1e30f, 0.f, 0.5f, 1e30f}) {
    std::fill(x.begin(), x.end(), v);
    f->Predict(x.data(), 3, &scores);
    for (const objects::ClassScore& s : scores) {
      if (s.cls >= f->num_classes() || !(s.confidence >= 0 && s.confidence <= 1.0001f)) {
        Fail("a prediction outside the model");
      }
    }
  }
  return 0;
}
