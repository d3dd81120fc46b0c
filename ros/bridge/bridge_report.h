// The skimap-ros node's exit report: the frame counters and ack latencies of its
// FrameSender, with the frames it could not send (no pose, bad message) and the process's
// CPU time, logged with ROS_INFO and, with ~stats_file, written there as one JSON object
// (the bridge benchmark and tests read it).
//
//   WriteReport(sender.Stats(), no_pose, bad, wall_seconds, params.stats_file);
//
// Thread safety: call once, at exit.
#ifndef ROS_BRIDGE_BRIDGE_REPORT_H_
#define ROS_BRIDGE_BRIDGE_REPORT_H_

#include <cstdint>
#include <string>

#include "ros/bridge/frame_sender.h"

namespace skimap::rosbridge {

// `stats_file`: "" writes no file.
void WriteReport(const SenderStats& s, uint64_t no_pose, uint64_t bad, double wall,
                 const std::string& stats_file);

}  // namespace skimap::rosbridge

#endif  // ROS_BRIDGE_BRIDGE_REPORT_H_
