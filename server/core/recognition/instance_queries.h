// InstanceQueries: the recognition side of the API over a MapService's maps: the
// instances recognition found (ListInstances, GetInstance, WatchInstances;
// instance_queries.cc) and the Labels volume (GetLabelVoxels; label_queries.cc), each voxel
// reduced to its heaviest label and that class's object. Both adapters hold one over the
// same MapService.
//
//   InstanceQueries instances(&maps);
//   absl::StatusOr<v1::ListInstancesResponse> page = instances.ListInstances(request);
//
// Errors (instances.proto): the map's lookup (MapService::FindMap); FailedPrecondition for
// a map without recognition; InvalidArgument naming the field (region, box, page_size,
// page_token, name). Page tokens are bound to the map and the query, like GetVoxels'.
//
// Thread safety: thread safe (no state but the MapService pointer).
#ifndef SERVER_CORE_RECOGNITION_INSTANCE_QUERIES_H_
#define SERVER_CORE_RECOGNITION_INSTANCE_QUERIES_H_

#include <functional>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "server/core/maps/map_service.h"
#include "skimap/v1/instances.pb.h"

namespace skimap::server {

class InstanceQueries {
 public:
  // REQUIRES: `maps` outlives this object.
  explicit InstanceQueries(const MapService* maps) : maps_(maps) {}

  absl::StatusOr<v1::ListInstancesResponse> ListInstances(
      const v1::ListInstancesRequest& request) const;
  absl::StatusOr<v1::Instance> GetInstance(const v1::GetInstanceRequest& request) const;
  // One page of the Labels volume in key order.
  absl::StatusOr<v1::GetLabelVoxelsResponse> GetLabelVoxels(
      const v1::GetLabelVoxelsRequest& request) const;

  // A watch of one map's instance events. Next() gives the events after the last one it
  // gave (at most `max`), starting after request.after_sequence; `wake` runs (on a map
  // thread; it must only schedule work) when new events may be there. Errors: the map's
  // lookup, FailedPrecondition (no recognition, events no longer kept), NotFound once the
  // map was deleted.
  class InstanceWatch {
   public:
    ~InstanceWatch();
    absl::StatusOr<std::vector<v1::InstanceEvent>> Next(size_t max);

   private:
    friend class InstanceQueries;
    InstanceWatch(std::shared_ptr<LiveMap> map, uint64_t after)
        : map_(std::move(map)), after_(after) {}
    std::shared_ptr<LiveMap> map_;
    uint64_t after_;
    uint64_t watcher_ = 0;
  };
  absl::StatusOr<std::unique_ptr<InstanceWatch>> WatchInstances(
      const v1::WatchInstancesRequest& request, std::function<void()> wake) const;

 private:
  const MapService* const maps_;
};

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_INSTANCE_QUERIES_H_
