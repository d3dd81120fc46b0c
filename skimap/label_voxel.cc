#include "skimap/label_voxel.h"

namespace skimap {

MultiLabelVoxel& MultiLabelVoxel::operator+=(const MultiLabelVoxel& o) {
  for (const Entry& e : o.entries_) {
    auto it = entries_.begin();
    while (it != entries_.end() && it->label < e.label) ++it;
    if (it != entries_.end() && it->label == e.label) {
      it->count += e.count;
    } else {
      entries_.insert(it, e);
    }
  }
  return *this;
}

MultiLabelVoxel& MultiLabelVoxel::operator-=(const MultiLabelVoxel& o) {
  for (const Entry& e : o.entries_) {
    auto it = entries_.begin();
    while (it != entries_.end() && it->label < e.label) ++it;
    if (it == entries_.end() || it->label != e.label) continue;
    if (it->count <= e.count) {
      entries_.erase(it);
    } else {
      it->count -= e.count;
    }
  }
  return *this;
}

uint32_t MultiLabelVoxel::Count(uint32_t label) const {
  for (const Entry& e : entries_) {
    if (e.label == label) return e.count;
  }
  return 0;
}

MultiLabelVoxel::Entry MultiLabelVoxel::Heaviest() const {
  Entry best{0, 0};
  for (const Entry& e : entries_) {
    if (e.count > best.count) best = e;
  }
  return best;
}

float MultiLabelVoxel::Weight() const {
  double total = 0;
  for (const Entry& e : entries_) total += e.count;
  return static_cast<float>(total);
}

void MultiLabelVoxel::Encode(Encoder& e) const {
  e.U32(static_cast<uint32_t>(entries_.size()));
  for (const Entry& entry : entries_) {
    e.U32(entry.label);
    e.U32(entry.count);
  }
}

bool MultiLabelVoxel::Decode(Decoder& d, MultiLabelVoxel* v) {
  uint32_t n;
  if (!d.U32(&n) || n > d.remaining() / 8) return false;
  absl::InlinedVector<Entry, 2> entries;
  entries.reserve(n);
  for (uint32_t i = 0; i < n; ++i) {
    Entry e;
    if (!d.U32(&e.label) || !d.U32(&e.count) || e.count == 0) return false;
    if (!entries.empty() && entries.back().label >= e.label) return false;
    entries.push_back(e);
  }
  v->entries_ = std::move(entries);
  return true;
}

}  // namespace skimap
