// FleetStreamer: a client that streams one map's frames into a fleet of skimapd nodes the
// way a robot should: over StreamFrames with a send window, following a node's redirect to
// the map's owner (FrameAck.redirect), and, when the node it streams to dies or cannot
// serve the map yet, going on through another node from the first frame not known to be
// in the map. A frame is confirmed by an OK ack, or by ALREADY_EXISTS when it is re-sent
// (it reached the map but its ack was lost). For the fleet tests and bench/fleet_bench.
//
//   FleetStreamer s({"127.0.0.1:5001", "127.0.0.1:5002"}, "maps/m0",
//                   [](uint64_t seq) { return MakeFrame("maps/m0", seq, View(seq)); });
//   absl::Status done = s.Run(0, 40, absl::Now() + absl::Seconds(60));
//
// Thread safety: one thread runs Run; the counters may be read from any thread.
#ifndef TESTS_COMMON_FLEET_STREAMER_H_
#define TESTS_COMMON_FLEET_STREAMER_H_

#include <algorithm>
#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "client/map_client.h"

namespace skimap::testing {

class FleetStreamer {
 public:
  using MakeFrameFn = std::function<v1::Frame(uint64_t sequence)>;
  // Called on the ack reader thread for every frame acknowledged OK, with the time from
  // its Send to its ack.
  using OnAckFn = std::function<void(uint64_t sequence, absl::Duration latency)>;

  FleetStreamer(std::vector<std::string> nodes, std::string map, MakeFrameFn make, int window = 4)
      : nodes_(std::move(nodes)), map_(std::move(map)), make_(std::move(make)), window_(window) {}

  void OnAck(OnAckFn fn) { on_ack_ = std::move(fn); }
  // Starts at nodes[i % size] (default 0).
  void StartAt(size_t i) { current_ = nodes_[i % nodes_.size()]; }

  // Sends frames [from, end) until each is confirmed, or `deadline` (DeadlineExceeded), or
  // an ack with an error a retry cannot fix (returned, naming the frame). After Stop, sends
  // no new frame and returns once every frame it sent is confirmed: the map then holds
  // frames [from, from + confirmed()).
  absl::Status Run(uint64_t from, uint64_t end, absl::Time deadline) {
    if (current_.empty()) current_ = nodes_[0];
    uint64_t next = from;
    std::set<uint64_t> confirmed;
    while (next < end) {
      if (stop_requested_) end = std::min(end, std::max(next, resent_below_));
      if (next >= end) break;
      if (absl::Now() > deadline) {
        return absl::DeadlineExceededError(absl::StrCat(map_, ": frame ", next, " unconfirmed"));
      }
      Round round;
      absl::Status s = Stream(next, end, &round);
      if (!s.ok()) return s;
      for (uint64_t q : round.confirmed) confirmed.insert(q);
      while (next < end && confirmed.contains(next)) ++next;
      confirmed_ = next - from;
      resent_below_ = std::max(resent_below_, round.sent_end);
      if (!round.redirect.empty()) {
        current_ = round.redirect;  // the owner
      } else if (round.failed) {
        ++failovers_;
        current_ = OtherNode(round.failed_node);
        absl::SleepFor(absl::Milliseconds(100));  // the lease of a dead owner runs out
      }
    }
    return absl::OkStatus();
  }

  // Ends Run early (from any thread): see Run.
  void Stop() { stop_requested_ = true; }
  uint64_t failovers() const { return failovers_.load(); }
  // Frames of the running (or last) Run confirmed so far, from its first on, in order
  // (counted as each stream of it ends).
  uint64_t confirmed() const { return confirmed_.load(); }
  // OK acks so far, counted as they arrive.
  uint64_t acked() const { return acked_.load(); }

 private:
  struct Round {
    std::vector<uint64_t> confirmed;
    uint64_t sent_end = 0;
    std::string redirect;  // owner named by a redirect ack
    bool failed = false;   // the node broke the stream or could not serve the map
    std::string failed_node;
  };

  std::string OtherNode(const std::string& bad) {
    for (size_t i = 0; i < nodes_.size(); ++i) {
      const std::string& n = nodes_[(rotation_++) % nodes_.size()];
      if (n != bad) return n;
    }
    return nodes_[0];
  }

  client::MapClient& Client(const std::string& address) {
    std::unique_ptr<client::MapClient>& c = clients_[address];
    if (c == nullptr) c = client::MapClient::Connect(address, {.timeout = absl::Seconds(10)});
    return *c;
  }

  absl::Status Stream(uint64_t from, uint64_t end, Round* round) {
    std::mutex mu;
    std::map<uint64_t, absl::Time> sent_at;
    std::atomic<bool> stop{false};
    absl::Status fatal;
    client::FrameStream::Options options;
    options.window = window_;
    options.on_ack = [&](const v1::FrameAck& ack) {
      std::lock_guard<std::mutex> lock(mu);
      const absl::StatusCode code = static_cast<absl::StatusCode>(ack.code());
      if (code == absl::StatusCode::kOk) {
        ++acked_;
        round->confirmed.push_back(ack.sequence());
        if (on_ack_) on_ack_(ack.sequence(), absl::Now() - sent_at[ack.sequence()]);
        return;
      }
      stop = true;
      if (code == absl::StatusCode::kAlreadyExists && ack.sequence() < resent_below_) {
        round->confirmed.push_back(ack.sequence());
        stop = false;
      } else if (ack.has_redirect()) {
        round->redirect = ack.redirect().address();
      } else if (code == absl::StatusCode::kUnavailable ||
                 code == absl::StatusCode::kFailedPrecondition) {
        round->failed = true;  // reloading, unloaded, or its lease lost: try elsewhere
        round->failed_node = current_;
      } else if (fatal.ok()) {
        fatal = absl::Status(code, absl::StrCat(map_, " frame ", ack.sequence(), " via ", current_,
                                                ": ", ack.message()));
      }
    };
    std::unique_ptr<client::FrameStream> stream = Client(current_).OpenFrameStream(options);
    uint64_t s = from;
    for (; s < end && !stop && !stop_requested_; ++s) {
      const v1::Frame frame = make_(s);
      {
        std::lock_guard<std::mutex> lock(mu);
        sent_at[s] = absl::Now();
      }
      if (!stream->Send(frame).ok()) break;
    }
    round->sent_end = s;
    if (!stream->Finish().ok()) {
      round->failed = true;
      round->failed_node = current_;
    }
    std::lock_guard<std::mutex> lock(mu);
    return fatal;
  }

  const std::vector<std::string> nodes_;
  const std::string map_;
  const MakeFrameFn make_;
  const int window_;
  OnAckFn on_ack_;
  std::string current_;
  size_t rotation_ = 1;
  uint64_t resent_below_ = 0;  // frames below this were sent before (ALREADY_EXISTS confirms)
  std::map<std::string, std::unique_ptr<client::MapClient>> clients_;
  std::atomic<uint64_t> failovers_{0};
  std::atomic<uint64_t> confirmed_{0};
  std::atomic<bool> stop_requested_{false};
  std::atomic<uint64_t> acked_{0};
};

}  // namespace skimap::testing

#endif  // TESTS_COMMON_FLEET_STREAMER_H_
