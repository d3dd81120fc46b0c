// FrameSender: the bridge's side of one StreamFrames call to skimapd. The ROS callbacks
// Offer() frames; one sender thread streams them with the client's ack window. The queue
// between them holds at most `queue_frames` frames: when the server (or the link) falls
// behind, a new frame is dropped and counted, never queued without bound, so the camera's
// callbacks never wait. A stream that fails is reopened (after a back-off of 0.5 s to
// 5 s); the frames it had in flight are counted as lost, not acknowledged.
//
// Each acknowledged frame's stamp and pose are kept (the trajectory, and the stamp ->
// sequence table pose updates use).
//
// Thread safety: Offer, Stats, Trajectory and SequenceOf from any thread.
#ifndef ROS_BRIDGE_FRAME_SENDER_H_
#define ROS_BRIDGE_FRAME_SENDER_H_

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "client/map_client.h"
#include "skimap/v1/frames.pb.h"

namespace skimap::rosbridge {

struct SenderStats {
  uint64_t offered = 0;  // frames the callbacks made
  uint64_t dropped = 0;  // not sent: the queue was full
  uint64_t sent = 0;
  uint64_t acked_ok = 0;
  uint64_t acked_failed = 0;  // acknowledged with an error (the first one: last_error)
  uint64_t lost = 0;          // in flight when a stream failed
  uint64_t reconnects = 0;
  std::string last_error;
  // Received (Offer's argument) to ack, milliseconds, of the acknowledged frames.
  std::vector<double> latencies_ms;
};

// One acknowledged frame: its stamp (ns), map sequence and camera pose.
struct SentFrame {
  int64_t stamp_ns = 0;
  uint64_t sequence = 0;
  v1::Pose pose;
};

class FrameSender {
 public:
  struct Options {
    std::string map_name;         // "maps/{id}"; created by the caller
    int window = 8;               // unacknowledged frames in flight
    int queue_frames = 2;         // frames waiting for the stream
    uint64_t first_sequence = 0;  // the map's frame count when the bridge started
  };
  FrameSender(client::MapClient* client, const Options& options);  // client not owned
  // Stops the stream: frames still queued are not sent; those in flight get up to 5 s for
  // their acks, then the call is cancelled. Known limit: a skimapd that stops reading
  // altogether (a stopped process, a hung host) leaves gRPC's blocking Write waiting even
  // after the cancel, and this destructor with it; the node then exits after
  // ~shutdown_timeout (skimap_ros_main.cc).
  ~FrameSender();

  using Clock = std::chrono::steady_clock;
  // Queues `frame` (map and sequence are set here) stamped `stamp_ns`, which reached the
  // node at `received` (the latency's start); false if the queue was full and the frame
  // dropped.
  bool Offer(v1::Frame frame, int64_t stamp_ns, Clock::time_point received);

  SenderStats Stats() const;
  // The acknowledged frames in sequence order, and a counter that changes when it does.
  std::vector<SentFrame> Trajectory(uint64_t* version = nullptr) const;
  // The sequence of the acknowledged frame stamped `stamp_ns` (within 1 us), if any.
  std::optional<uint64_t> SequenceOf(int64_t stamp_ns) const;
  // Replaces the poses of acknowledged frames (after UpdatePoses succeeded).
  void SetPoses(const std::vector<std::pair<uint64_t, v1::Pose>>& poses);
  // Waits until every offered frame is acknowledged, dropped or lost (tests, shutdown).
  bool WaitIdle(std::chrono::milliseconds timeout);

 private:
  struct Queued {
    v1::Frame frame;
    int64_t stamp_ns;
    Clock::time_point offered;
  };
  void Run();         // RunStreams, then run_done_
  void RunStreams();  // streams until stop_
  void OnAck(const v1::FrameAck& ack);

  client::MapClient* const client_;
  const Options options_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Queued> queue_;               // guarded by mu_
  bool stop_ = false;                      // guarded by mu_
  uint64_t next_sequence_;                 // guarded by mu_
  std::map<uint64_t, Queued> in_flight_;   // by sequence; guarded by mu_ (frame cleared)
  SenderStats stats_;                      // guarded by mu_
  std::map<uint64_t, SentFrame> acked_;    // by sequence; guarded by mu_
  std::map<int64_t, uint64_t> by_stamp_;   // stamp -> sequence; guarded by mu_
  uint64_t version_ = 0;                   // guarded by mu_
  client::FrameStream* stream_ = nullptr;  // the open call; guarded by mu_
  bool run_done_ = false;                  // guarded by mu_
  std::thread thread_;
};

}  // namespace skimap::rosbridge

#endif  // ROS_BRIDGE_FRAME_SENDER_H_
