// MapEvents: the live updates of the viewer, GET /v1/maps/{map}/events as server-sent
// events (text/event-stream). A stream first sends the map as it is, then one event per
// batch of writes (frames integrated, poses updated while the last event was being sent
// coalesce into one), each the map's stats:
//
//   event: map
//   data: {"name":"maps/kitchen","stats":{"voxels":"123456",...},...}   (v1.Map as JSON)
//
// and a comment line (": keep-alive") after `heartbeat` of silence, which also notices
// clients that left. When the map is deleted or unloaded the stream sends `event: gone`
// and ends (a browser's EventSource reconnects and finds the map again or a 404).
//
// A stream holds one HTTP thread while open, so at most `max_clients` are open at once;
// another answers 429. Stop() (skimapd's shutdown) ends every stream within a moment and
// refuses new ones with 503, so that the HTTP server can stop without waiting for clients.
//
// Thread safety: thread safe.
#ifndef SERVER_HTTP_MAP_EVENTS_H_
#define SERVER_HTTP_MAP_EVENTS_H_

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"
#include "base/mutex.h"
#include "server/core/maps/map_service.h"
#include "server/http/rest_route.h"

namespace skimap::server {

class MapEvents {
 public:
  struct Options {
    int max_clients = 4;  // streams open at once, >= 0 (keep it below the HTTP threads)
    absl::Duration heartbeat = absl::Seconds(10);
  };

  // REQUIRES: `maps` outlives this object.
  MapEvents(MapService& maps, const Options& options);
  ~MapEvents();  // Stop()

  // The route's handler: a reply whose `stream` runs the event stream of map
  // call.path["map"]. NotFound for an unknown map, ResourceExhausted (429) with
  // max_clients streams open, Unavailable (503) after Stop().
  absl::StatusOr<RestReply> Open(const RestCall& call);

  // Ends the open streams (they return from their `stream` within a moment) and refuses
  // new ones. Idempotent.
  void Stop();

  int open_streams();

 private:
  struct Stream;
  // Runs on the HTTP thread until the client leaves, the map goes, or Stop().
  void Run(const std::string& name, Stream& stream, MapService::MapWatch& watch,
           const std::function<bool(std::string_view)>& write);

  MapService& maps_;
  const Options options_;
  Mutex mu_;
  CondVar changed_;  // a watched map changed, or Stop()
  bool stopping_ ABSL_GUARDED_BY(mu_) = false;
  int open_ ABSL_GUARDED_BY(mu_) = 0;
};

// One server-sent event: "event: <type>\ndata: <data>\n\n" (REQUIRES: `data` is one line).
std::string ServerSentEvent(absl::string_view type, absl::string_view data);

}  // namespace skimap::server

#endif  // SERVER_HTTP_MAP_EVENTS_H_
