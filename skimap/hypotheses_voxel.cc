#include "skimap/hypotheses_voxel.h"

#include <algorithm>

namespace skimap {
namespace {

void EncodePose(Encoder& e, const std::array<float, 3>& t, const std::array<float, 4>& q) {
  for (float v : t) e.F32(v);
  for (float v : q) e.F32(v);
}
bool DecodePose(Decoder& d, std::array<float, 3>* t, std::array<float, 4>* q) {
  for (float& v : *t) {
    if (!d.F32(&v)) return false;
  }
  for (float& v : *q) {
    if (!d.F32(&v)) return false;
  }
  return true;
}

}  // namespace

HypothesesVoxel& HypothesesVoxel::operator+=(const HypothesesVoxel& o) {
  for (const Hypothesis& h : o.items_) {
    if (std::find(items_.begin(), items_.end(), h) == items_.end()) items_.push_back(h);
  }
  return *this;
}

HypothesesVoxel& HypothesesVoxel::operator-=(const HypothesesVoxel& o) {
  std::erase_if(items_, [&](const Hypothesis& h) {
    return std::find(o.items_.begin(), o.items_.end(), h) != o.items_.end();
  });
  return *this;
}

float HypothesesVoxel::Weight() const {
  float total = 0;
  for (const Hypothesis& h : items_) total += h.score;
  return total;
}

void HypothesesVoxel::Encode(Encoder& e) const {
  e.U32(static_cast<uint32_t>(items_.size()));
  for (const Hypothesis& h : items_) {
    EncodePose(e, h.t, h.q);
    e.U32(h.object_id);
    e.F32(h.score);
    e.U64(h.frame);
  }
}

bool HypothesesVoxel::Decode(Decoder& d, HypothesesVoxel* v) {
  constexpr size_t kBytes = 9 * 4 + 8;
  uint32_t n;
  if (!d.U32(&n) || n > d.remaining() / kBytes) return false;
  std::vector<Hypothesis> items(n);
  for (Hypothesis& h : items) {
    if (!DecodePose(d, &h.t, &h.q) || !d.U32(&h.object_id) || !d.F32(&h.score) ||
        !d.U64(&h.frame)) {
      return false;
    }
  }
  v->items_ = std::move(items);
  return true;
}

InstancesVoxel& InstancesVoxel::operator+=(const InstancesVoxel& o) {
  for (const Instance& i : o.items_) {
    auto it = std::find_if(items_.begin(), items_.end(),
                           [&](const Instance& mine) { return mine.id == i.id; });
    if (it == items_.end()) {
      items_.push_back(i);
    } else {
      *it = i;
    }
  }
  return *this;
}

InstancesVoxel& InstancesVoxel::operator-=(const InstancesVoxel& o) {
  std::erase_if(items_, [&](const Instance& mine) {
    return std::any_of(o.items_.begin(), o.items_.end(),
                       [&](const Instance& i) { return i.id == mine.id; });
  });
  return *this;
}

// Bit 31 of an InstancesVoxel's count: its items carry the view counts (every writer since
// 2026-11-27; earlier files lack them and read as 0).
constexpr uint32_t kWithViewCounts = 0x80000000u;

void InstancesVoxel::Encode(Encoder& e) const {
  e.U32(static_cast<uint32_t>(items_.size()) | kWithViewCounts);
  for (const Instance& i : items_) {
    e.U64(i.id);
    e.U32(i.object_id);
    EncodePose(e, i.t, i.q);
    e.F32(i.score);
    e.U32(i.support);
    e.U32(i.frames);
    e.U64(i.first_frame);
    e.U64(i.last_frame);
    e.U64(static_cast<uint64_t>(i.first_time_us));
    e.U64(static_cast<uint64_t>(i.last_time_us));
    e.F32(i.spread_t);
    e.F32(i.spread_r);
    e.F32(i.fit);
    e.U32(i.view_agree);
    e.U32(i.view_conflict);
  }
}

bool InstancesVoxel::Decode(Decoder& d, InstancesVoxel* v) {
  uint32_t n;
  if (!d.U32(&n)) return false;
  const bool with_view = (n & kWithViewCounts) != 0;
  n &= ~kWithViewCounts;
  const size_t bytes = 8 + 4 + 7 * 4 + 4 + 4 + 4 + 4 * 8 + 3 * 4 + (with_view ? 8 : 0);
  if (n > d.remaining() / bytes) return false;
  std::vector<Instance> items(n);
  for (size_t k = 0; k < items.size(); ++k) {
    Instance& i = items[k];
    uint64_t first_time = 0, last_time = 0;
    if (!d.U64(&i.id) || !d.U32(&i.object_id) || !DecodePose(d, &i.t, &i.q) || !d.F32(&i.score) ||
        !d.U32(&i.support) || !d.U32(&i.frames) || !d.U64(&i.first_frame) ||
        !d.U64(&i.last_frame) || !d.U64(&first_time) || !d.U64(&last_time) || !d.F32(&i.spread_t) ||
        !d.F32(&i.spread_r) || !d.F32(&i.fit) ||
        (with_view && (!d.U32(&i.view_agree) || !d.U32(&i.view_conflict)))) {
      return false;
    }
    i.first_time_us = static_cast<int64_t>(first_time);
    i.last_time_us = static_cast<int64_t>(last_time);
    for (size_t j = 0; j < k; ++j) {
      if (items[j].id == i.id) return false;
    }
  }
  v->items_ = std::move(items);
  return true;
}

}  // namespace skimap
