#include "server/maps/recognition_queue.h"

#include <utility>

namespace skimap::server {

RecognitionQueue::RecognitionQueue(const Options& options, std::function<void(RecognitionJob&)> run)
    : options_(options), run_(std::move(run)), thread_([this] { Loop(); }) {}

RecognitionQueue::~RecognitionQueue() {
  std::deque<RecognitionJob> left;
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
    left.swap(jobs_);
  }
  cv_.notify_all();
  thread_.join();
  for (RecognitionJob& job : left) {
    if (job.done) job.done();
  }
}

void RecognitionQueue::Offer(RecognitionJob job) {
  std::function<void()> dropped;
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (stopping_) {
      dropped = std::move(job.done);
    } else {
      if (!options_.every_frame && !jobs_.empty()) {
        dropped = std::move(jobs_.front().done);
        jobs_.clear();
        skipped_.fetch_add(1, std::memory_order_relaxed);
      }
      jobs_.push_back(std::move(job));
    }
  }
  cv_.notify_all();
  if (dropped) dropped();
}

void RecognitionQueue::Flush() {
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait(lock, [this] { return stopping_ || (jobs_.empty() && !running_); });
}

void RecognitionQueue::Loop() {
  for (;;) {
    RecognitionJob job;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      if (stopping_) return;
      job = std::move(jobs_.front());
      jobs_.pop_front();
      running_ = true;
    }
    run_(job);
    if (job.done) job.done();
    {
      std::lock_guard<std::mutex> lock(mu_);
      running_ = false;
    }
    cv_.notify_all();
  }
}

}  // namespace skimap::server
