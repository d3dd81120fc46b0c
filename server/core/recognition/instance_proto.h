// The API view of a map's instance (instances.proto Instance): its names, pose, score and
// the score's scale for its object (recognition_config.h InstanceVisibility), support,
// sightings, spread, fit and view conflict (instance_checks.h).
//
//   v1::Instance api = ToProto(instance, map.recognition_model(), map.id());
//
// Thread safety: a pure function.
#ifndef SERVER_CORE_RECOGNITION_INSTANCE_PROTO_H_
#define SERVER_CORE_RECOGNITION_INSTANCE_PROTO_H_

#include <string>

#include "perception/recognition/recognition_model.h"
#include "server/core/maps/map_state.h"
#include "skimap/v1/instances.pb.h"

namespace skimap::server {

// The API view of an instance of map `map_id`; `model` (may be null) names its object and
// scales its score.
v1::Instance ToProto(const Instance& instance, const recognition::RecognitionModel* model,
                     const std::string& map_id);

}  // namespace skimap::server

#endif  // SERVER_CORE_RECOGNITION_INSTANCE_PROTO_H_
