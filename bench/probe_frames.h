// Dataset frames as the server sees them, for the recognition probes (label_probe,
// vote_probe): the client's encoding (client/cli/dataset_frames.h ToApiFrame) decoded by
// the server's own decoder (server/core/maps/frame_decode.h DecodeFrame), so a probe's
// labels are the map's.
//
// Thread safety: a pure function.
#ifndef BENCH_PROBE_FRAMES_H_
#define BENCH_PROBE_FRAMES_H_

#include "absl/status/statusor.h"
#include "client/cli/dataset_frames.h"
#include "dataset/types.h"
#include "perception/rgbd_frame.h"
#include "server/core/maps/frame_decode.h"

namespace skimap::bench {

inline absl::StatusOr<perception::RgbdFrame> ProbeFrame(const dataset::Frame& f) {
  absl::StatusOr<v1::Frame> api = client::ToApiFrame(f, "maps/probe", f.id + 1);
  if (!api.ok()) return api.status();
  return server::DecodeFrame(*api);
}

}  // namespace skimap::bench

#endif  // BENCH_PROBE_FRAMES_H_
