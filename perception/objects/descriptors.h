// DescriptorMatrix: rows of feature descriptors of one layout, binary or float.
//
// Binary descriptors (ORB, BRISK, AKAZE's MLDB) are packed bits, compared with the Hamming
// distance (in bits); float descriptors (SIFT) are float vectors compared with the
// Euclidean (L2) distance. For the random forest both become float feature vectors:
// binary bits unpacked to 0.0 / 1.0 (one feature per bit), float descriptors unchanged.
//
// Thread safety: values; concurrent const access is safe.
#ifndef SKIMAP_PERCEPTION_OBJECTS_DESCRIPTORS_H_
#define SKIMAP_PERCEPTION_OBJECTS_DESCRIPTORS_H_

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "base/encoding.h"

namespace skimap::objects {

enum class DescriptorKind : uint8_t { kBinary = 1, kFloat = 2 };

// The shape of one descriptor. dims: bits (binary, a multiple of 8) or floats.
struct DescriptorLayout {
  DescriptorKind kind = DescriptorKind::kBinary;
  int dims = 0;

  bool binary() const { return kind == DescriptorKind::kBinary; }
  // Bytes of one packed binary row (dims / 8) or floats of one float row (dims).
  int Elements() const { return binary() ? dims / 8 : dims; }
  // Memory of one descriptor in bytes.
  size_t RowBytes() const { return binary() ? dims / 8 : dims * sizeof(float); }
  // Number of forest features (= dims in both cases).
  int FeatureDims() const { return dims; }
  friend bool operator==(const DescriptorLayout&, const DescriptorLayout&) = default;
};

// A view of one descriptor: exactly one of bits / values is set, per the layout.
struct DescriptorRef {
  const uint8_t* bits = nullptr;  // binary: dims / 8 bytes
  const float* values = nullptr;  // float: dims floats
};

// Distance between two descriptors of `layout`: Hamming bits or L2.
float DescriptorDistance(const DescriptorLayout& layout, DescriptorRef a, DescriptorRef b);

// Writes the forest features of `d` (dims floats) into out (REQUIRES: out.size() >= dims).
void ToFeatures(const DescriptorLayout& layout, DescriptorRef d, std::span<float> out);

class DescriptorMatrix {
 public:
  DescriptorMatrix() = default;
  explicit DescriptorMatrix(const DescriptorLayout& layout) : layout_(layout) {}

  const DescriptorLayout& layout() const { return layout_; }
  size_t rows() const { return rows_; }
  bool empty() const { return rows_ == 0; }

  // Row i (REQUIRES: i < rows()).
  DescriptorRef Row(size_t i) const;
  // Appends one descriptor of the same layout.
  void Append(DescriptorRef d);
  // Appends raw packed bits (binary layout) / floats (float layout).
  void AppendBits(const uint8_t* bits);
  void AppendValues(const float* values);
  // Appends every row of `o` (REQUIRES: same layout, or this matrix has no rows and no
  // layout yet, in which case it takes o's layout).
  void AppendAll(const DescriptorMatrix& o);
  // Removes row i by moving the last row into its place.
  void SwapRemove(size_t i);
  // Index of a row bitwise equal to d, or -1.
  long Find(DescriptorRef d) const;
  void Reserve(size_t rows);
  void Clear();

  // Bytes of the descriptor payload (rows * RowBytes) and of heap capacity.
  size_t PayloadBytes() const { return rows_ * layout_.RowBytes(); }
  size_t HeapBytes() const { return bits_.capacity() + values_.capacity() * sizeof(float); }

  // Little-endian encoding: kind u8, dims u32, rows u32, then the rows (bytes or f32).
  void Encode(Encoder& e) const;
  // False on truncated or inconsistent input (dims not a multiple of 8 for binary,
  // absurd sizes).
  static bool Decode(Decoder& d, DescriptorMatrix* out);

  friend bool operator==(const DescriptorMatrix&, const DescriptorMatrix&) = default;

 private:
  DescriptorLayout layout_;
  size_t rows_ = 0;
  std::vector<uint8_t> bits_;
  std::vector<float> values_;
};

// Checks a layout: binary dims > 0 and a multiple of 8, float dims > 0, both <= 4096.
absl::Status ValidateLayout(const DescriptorLayout& layout);

}  // namespace skimap::objects

#endif  // SKIMAP_PERCEPTION_OBJECTS_DESCRIPTORS_H_
