// InstanceLog: a map's instance change events (created / updated / merged / removed), each
// with the next sequence number, kept in memory up to a window for WatchInstances. The last
// sequence number is persisted with the map (map_meta.h), so numbers are never reused;
// events themselves are not: after a restart a watcher resumes from a listing
// (ListInstancesResponse.event_sequence).
//
//   log.Append(event);                     // sets event.sequence
//   std::vector<v1::InstanceEvent> e;
//   absl::Status s = log.After(7, 100, &e);  // events 8.. (at most 100)
//
// Thread safety: a plain value; LiveMap guards it with the map's snapshot lock.
#ifndef SERVER_CORE_RECOGNITION_INSTANCE_LOG_H_
#define SERVER_CORE_RECOGNITION_INSTANCE_LOG_H_

#include <cstdint>
#include <deque>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "skimap/v1/instances.pb.h"

namespace skimap::server {

class InstanceLog {
 public:
  static constexpr size_t kWindow = 10000;  // events kept

  // Sets event.sequence to last_sequence() + 1 and keeps it (dropping the oldest beyond
  // the window).
  void Append(v1::InstanceEvent event) {
    event.set_sequence(++last_);
    events_.push_back(std::move(event));
    if (events_.size() > kWindow) events_.pop_front();
  }
  // Appends the events with sequence > after (at most `max`) to `out`. FailedPrecondition
  // when some of them are no longer kept; OK and nothing when there is none yet.
  absl::Status After(uint64_t after, size_t max, std::vector<v1::InstanceEvent>* out) const {
    const uint64_t first_kept = last_ - events_.size() + 1;
    if (after + 1 < first_kept) {
      return absl::FailedPreconditionError(absl::StrCat(
          "after_sequence: events ", after + 1, "..", first_kept - 1,
          " are no longer kept (kept: the last ", kWindow,
          " since the map was loaded); list the instances and watch from the listing's "
          "event_sequence"));
    }
    for (uint64_t s = after + 1; s <= last_ && out->size() < max; ++s) {
      out->push_back(events_[s - first_kept]);
    }
    return absl::OkStatus();
  }
  uint64_t last_sequence() const { return last_; }
  // After a reload: numbering goes on from `last`; nothing before it is kept.
  void Restart(uint64_t last) {
    events_.clear();
    last_ = last;
  }

 private:
  std::deque<v1::InstanceEvent> events_;
  uint64_t last_ = 0;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_INSTANCE_LOG_H_
