#include "ros/bridge/frame_sender.h"

#include <cstdlib>

#include "absl/strings/str_cat.h"

namespace skimap::rosbridge {

FrameSender::FrameSender(client::MapClient* client, const Options& options)
    : client_(client), options_(options), next_sequence_(options.first_sequence) {
  thread_ = std::thread([this] { Run(); });
}

FrameSender::~FrameSender() {
  {
    std::unique_lock<std::mutex> lock(mu_);
    stop_ = true;
    cv_.notify_all();
    if (!cv_.wait_for(lock, std::chrono::seconds(5), [&] { return run_done_; }) &&
        stream_ != nullptr) {
      stream_->Cancel();
    }
  }
  thread_.join();
}

bool FrameSender::Offer(v1::Frame frame, int64_t stamp_ns, Clock::time_point received) {
  std::lock_guard<std::mutex> lock(mu_);
  ++stats_.offered;
  if (stop_ || queue_.size() >= size_t(std::max(1, options_.queue_frames))) {
    ++stats_.dropped;
    return false;
  }
  queue_.push_back(Queued{std::move(frame), stamp_ns, received});
  cv_.notify_all();
  return true;
}

void FrameSender::OnAck(const v1::FrameAck& ack) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = in_flight_.find(ack.sequence());
  if (it == in_flight_.end()) return;
  if (ack.code() == 0) {
    ++stats_.acked_ok;
    stats_.latencies_ms.push_back(
        std::chrono::duration<double, std::milli>(Clock::now() - it->second.offered).count());
    SentFrame& sent = acked_[ack.sequence()];
    sent.stamp_ns = it->second.stamp_ns;
    sent.sequence = ack.sequence();
    sent.pose = it->second.frame.pose();
    by_stamp_[sent.stamp_ns] = sent.sequence;
    ++version_;
  } else {
    ++stats_.acked_failed;
    stats_.last_error = absl::StrCat("frame ", ack.sequence(), ": ", ack.message());
  }
  in_flight_.erase(it);
  cv_.notify_all();
}

void FrameSender::Run() {
  RunStreams();
  std::lock_guard<std::mutex> lock(mu_);
  run_done_ = true;
  cv_.notify_all();
}

void FrameSender::RunStreams() {
  auto backoff = std::chrono::milliseconds(500);
  while (true) {
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
    }
    client::FrameStream::Options stream_options;
    stream_options.window = options_.window;
    stream_options.on_ack = [this](const v1::FrameAck& ack) { OnAck(ack); };
    std::unique_ptr<client::FrameStream> stream =
        client_->OpenFrameStream(stream_options, options_.map_name);
    {
      std::lock_guard<std::mutex> lock(mu_);
      stream_ = stream.get();
    }
    bool failed = false;
    while (!failed) {
      Queued next;
      {
        std::unique_lock<std::mutex> lock(mu_);
        cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) break;
        next = std::move(queue_.front());
        queue_.pop_front();
        next.frame.set_map(options_.map_name);
        next.frame.set_sequence(next_sequence_++);
        Queued record{v1::Frame(), next.stamp_ns, next.offered};
        *record.frame.mutable_pose() = next.frame.pose();
        in_flight_[next.frame.sequence()] = std::move(record);
        ++stats_.sent;
      }
      failed = !stream->Send(next.frame).ok();
    }
    absl::StatusOr<std::vector<v1::FrameAck>> done = stream->Finish();
    std::unique_lock<std::mutex> lock(mu_);
    stream_ = nullptr;
    if (!done.ok() || failed) {
      stats_.lost += in_flight_.size();
      in_flight_.clear();
      ++stats_.reconnects;
      stats_.last_error = done.ok() ? "stream closed" : std::string(done.status().message());
      cv_.notify_all();
      if (stop_) return;
      // The frames after the lost ones keep their sequences: the map sees a gap.
      lock.unlock();
      std::this_thread::sleep_for(backoff);
      backoff = std::min(backoff * 2, std::chrono::milliseconds(5000));
      continue;
    }
    backoff = std::chrono::milliseconds(500);
    if (stop_) return;
  }
}

SenderStats FrameSender::Stats() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stats_;
}

std::vector<SentFrame> FrameSender::Trajectory(uint64_t* version) const {
  std::lock_guard<std::mutex> lock(mu_);
  if (version != nullptr) *version = version_;
  std::vector<SentFrame> out;
  out.reserve(acked_.size());
  for (const auto& [sequence, frame] : acked_) out.push_back(frame);
  return out;
}

std::optional<uint64_t> FrameSender::SequenceOf(int64_t stamp_ns) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = by_stamp_.lower_bound(stamp_ns - 1000);
  if (it == by_stamp_.end() || std::llabs(it->first - stamp_ns) > 1000) return std::nullopt;
  return it->second;
}

void FrameSender::SetPoses(const std::vector<std::pair<uint64_t, v1::Pose>>& poses) {
  std::lock_guard<std::mutex> lock(mu_);
  for (const auto& [sequence, pose] : poses) {
    auto it = acked_.find(sequence);
    if (it != acked_.end()) it->second.pose = pose;
  }
  ++version_;
}

bool FrameSender::WaitIdle(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mu_);
  return cv_.wait_for(lock, timeout, [&] { return queue_.empty() && in_flight_.empty(); });
}

}  // namespace skimap::rosbridge
