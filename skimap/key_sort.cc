#include "skimap/key_sort.h"

#include <utility>

namespace skimap::internal {

uint64_t* RadixSort(uint64_t* a, uint64_t* b, size_t n, int shift, int bits) {
  if (bits <= 0 || n <= 1) return a;
  // Digits of at most 12 bits (4096 counters per pass stay in L1), all histograms taken in
  // one sweep over the keys.
  constexpr int kMaxDigitBits = 12;
  const int passes = (bits + kMaxDigitBits - 1) / kMaxDigitBits;
  const int digit = (bits + passes - 1) / passes;
  const uint64_t mask = (uint64_t{1} << digit) - 1;
  std::vector<uint32_t> count(size_t(passes) << digit, 0);
  for (size_t i = 0; i < n; ++i) {
    const uint64_t v = a[i] >> shift;
    for (int p = 0; p < passes; ++p) ++count[(size_t(p) << digit) + ((v >> (p * digit)) & mask)];
  }
  for (int p = 0; p < passes; ++p) {
    uint32_t* c = count.data() + (size_t(p) << digit);
    uint32_t sum = 0;
    for (size_t d = 0; d <= mask; ++d) sum += std::exchange(c[d], sum);
    const int s = shift + p * digit;
    for (size_t i = 0; i < n; ++i) b[c[(a[i] >> s) & mask]++] = a[i];
    std::swap(a, b);
  }
  return a;
}

std::vector<size_t> PartitionByTopBits(const uint64_t* a, uint64_t* b, size_t n, int shift,
                                       int bits, int top_bits, size_t parts) {
  const int top_shift = shift + bits - top_bits;
  const size_t buckets = size_t{1} << top_bits;
  std::vector<size_t> count(buckets, 0);
  for (size_t i = 0; i < n; ++i) ++count[(a[i] >> top_shift) & (buckets - 1)];
  // Bucket -> part, cutting where the running count passes p * n / parts.
  std::vector<uint32_t> part_of(buckets);
  std::vector<size_t> offsets(parts + 1, n);
  offsets[0] = 0;
  size_t sum = 0, part = 0;
  for (size_t k = 0; k < buckets; ++k) {
    while (part + 1 < parts && sum >= (part + 1) * n / parts) offsets[++part] = sum;
    part_of[k] = static_cast<uint32_t>(part);
    sum += count[k];
  }
  while (part + 1 < parts) offsets[++part] = n;
  std::vector<size_t> next(offsets.begin(), offsets.end() - 1);
  for (size_t i = 0; i < n; ++i) b[next[part_of[(a[i] >> top_shift) & (buckets - 1)]]++] = a[i];
  return offsets;
}

}  // namespace skimap::internal
