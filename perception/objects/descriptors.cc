#include "perception/objects/descriptors.h"

#include <bit>
#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace skimap::objects {

float DescriptorDistance(const DescriptorLayout& layout, DescriptorRef a, DescriptorRef b) {
  if (layout.binary()) {
    const int n = layout.dims / 8;
    int bits = 0;
    int i = 0;
    for (; i + 8 <= n; i += 8) {
      uint64_t x, y;
      std::memcpy(&x, a.bits + i, 8);
      std::memcpy(&y, b.bits + i, 8);
      bits += std::popcount(x ^ y);
    }
    for (; i < n; ++i) bits += std::popcount(static_cast<unsigned>(a.bits[i] ^ b.bits[i]));
    return static_cast<float>(bits);
  }
  float s = 0;
  for (int i = 0; i < layout.dims; ++i) {
    const float d = a.values[i] - b.values[i];
    s += d * d;
  }
  return std::sqrt(s);
}

void ToFeatures(const DescriptorLayout& layout, DescriptorRef d, std::span<float> out) {
  if (layout.binary()) {
    for (int i = 0; i < layout.dims; ++i)
      out[i] = static_cast<float>((d.bits[i >> 3] >> (i & 7)) & 1);
  } else {
    std::memcpy(out.data(), d.values, layout.dims * sizeof(float));
  }
}

DescriptorRef DescriptorMatrix::Row(size_t i) const {
  if (layout_.binary()) return {.bits = bits_.data() + i * (layout_.dims / 8)};
  return {.values = values_.data() + i * layout_.dims};
}

void DescriptorMatrix::Append(DescriptorRef d) {
  if (layout_.binary()) {
    AppendBits(d.bits);
  } else {
    AppendValues(d.values);
  }
}

void DescriptorMatrix::AppendBits(const uint8_t* bits) {
  bits_.insert(bits_.end(), bits, bits + layout_.dims / 8);
  ++rows_;
}

void DescriptorMatrix::AppendValues(const float* values) {
  values_.insert(values_.end(), values, values + layout_.dims);
  ++rows_;
}

void DescriptorMatrix::AppendAll(const DescriptorMatrix& o) {
  if (o.rows_ == 0) return;
  if (rows_ == 0 && layout_.dims == 0) layout_ = o.layout_;
  bits_.insert(bits_.end(), o.bits_.begin(), o.bits_.end());
  values_.insert(values_.end(), o.values_.begin(), o.values_.end());
  rows_ += o.rows_;
}

void DescriptorMatrix::SwapRemove(size_t i) {
  const size_t n = layout_.Elements();
  const size_t last = rows_ - 1;
  if (layout_.binary()) {
    if (i != last) std::memcpy(&bits_[i * n], &bits_[last * n], n);
    bits_.resize(last * n);
  } else {
    if (i != last) std::memcpy(&values_[i * n], &values_[last * n], n * sizeof(float));
    values_.resize(last * n);
  }
  rows_ = last;
}

long DescriptorMatrix::Find(DescriptorRef d) const {
  const size_t bytes = layout_.RowBytes();
  for (size_t i = 0; i < rows_; ++i) {
    const DescriptorRef r = Row(i);
    const bool same = layout_.binary() ? std::memcmp(r.bits, d.bits, bytes) == 0
                                       : std::memcmp(r.values, d.values, bytes) == 0;
    if (same) return static_cast<long>(i);
  }
  return -1;
}

void DescriptorMatrix::Reserve(size_t rows) {
  if (layout_.binary()) {
    bits_.reserve(rows * layout_.Elements());
  } else {
    values_.reserve(rows * layout_.Elements());
  }
}

void DescriptorMatrix::Clear() {
  rows_ = 0;
  bits_.clear();
  values_.clear();
}

void DescriptorMatrix::Encode(Encoder& e) const {
  e.U8(static_cast<uint8_t>(layout_.kind));
  e.U32(static_cast<uint32_t>(layout_.dims));
  e.U32(static_cast<uint32_t>(rows_));
  if (layout_.binary()) {
    e.Bytes(std::string_view(reinterpret_cast<const char*>(bits_.data()), bits_.size()));
  } else {
    for (float v : values_) e.F32(v);
  }
}

bool DescriptorMatrix::Decode(Decoder& d, DescriptorMatrix* out) {
  uint8_t kind = 0;
  uint32_t dims = 0, rows = 0;
  if (!d.U8(&kind) || !d.U32(&dims) || !d.U32(&rows)) return false;
  DescriptorLayout layout{static_cast<DescriptorKind>(kind), static_cast<int>(dims)};
  if (dims == 0 && rows == 0) {
    *out = DescriptorMatrix();
    return true;
  }
  if (!ValidateLayout(layout).ok() || rows > (1u << 26)) return false;
  if (size_t{rows} * layout.RowBytes() > d.remaining()) return false;
  DescriptorMatrix m(layout);
  if (layout.binary()) {
    const size_t n = size_t{rows} * layout.Elements();
    m.bits_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      if (!d.U8(&m.bits_[i])) return false;
    }
  } else {
    const size_t n = size_t{rows} * layout.Elements();
    m.values_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      if (!d.F32(&m.values_[i])) return false;
    }
  }
  m.rows_ = rows;
  *out = std::move(m);
  return true;
}

absl::Status ValidateLayout(const DescriptorLayout& layout) {
  if (layout.kind != DescriptorKind::kBinary && layout.kind != DescriptorKind::kFloat) {
    return absl::InvalidArgumentError(
        absl::StrCat("descriptor layout: kind ", static_cast<int>(layout.kind), " unknown"));
  }
  if (layout.dims <= 0 || layout.dims > 4096 || (layout.binary() && layout.dims % 8 != 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("descriptor layout: dims ", layout.dims,
                     " must be in 1..4096 (a multiple of 8 for binary descriptors)"));
  }
  return absl::OkStatus();
}

}  // namespace skimap::objects
