// `skimap instances`: the object instances recognition found in a map, optionally in a
// region, of some objects, above a score; as text or as JSON in the BOP convention.
//
//   skimap instances --map=ID [--box=X0,Y0,Z0,X1,Y1,Z1 | --sphere=X,Y,Z,R]
//                    [--objects=1,5] [--min_score=S] [--json]
//
// JSON: an array, one object per instance, in the world frame of the streamed dataset
// (the map's frame): {"id", "obj_id", "object_name", "score", "fit", "frames",
// "hypotheses", "R": the object-to-world rotation, 3x3 row-major, "t": the object's
// origin in millimetres} - the fields a BOP-style scorer reads (obj_id, R, t, score).
//
// Thread safety: one call at a time (the client itself is shared).
#ifndef CLIENT_CLI_INSTANCES_COMMAND_H_
#define CLIENT_CLI_INSTANCES_COMMAND_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/map_client.h"

namespace skimap::client {

struct InstancesOptions {
  std::string map_id;
  std::string box;      // "X0,Y0,Z0,X1,Y1,Z1" metres, or empty
  std::string sphere;   // "X,Y,Z,R" metres, or empty
  std::string objects;  // "1,5": obj_ids, or empty for all
  double min_score = 0;
  bool json = false;
};

// The ListInstances request the options describe; InvalidArgument naming the flag when one
// is malformed (wrong count, not a number, box and sphere both given).
absl::StatusOr<v1::ListInstancesRequest> InstancesRequest(const InstancesOptions& options);

// The instances as the command prints them (JSON array or one line each).
std::string FormatInstances(const std::vector<v1::Instance>& instances, bool json);

// Lists and prints; the call's error otherwise.
absl::Status RunInstancesCommand(MapClient& client, const InstancesOptions& options);

}  // namespace skimap::client

#endif  // CLIENT_CLI_INSTANCES_COMMAND_H_
