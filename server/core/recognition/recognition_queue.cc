#include "server/core/recognition/recognition_queue.h"

#include <algorithm>
#include <utility>

#include "base/thread_pool.h"

namespace skimap::server {

int RecognitionNice(bool every_frame, int ingest_nice) {
  constexpr int kStep = 10;
  return every_frame ? 0 : std::min(19, ingest_nice + kStep);
}

RecognitionQueue::RecognitionQueue(const Options& options,
                                   std::function<void(RecognitionJob&)> prepare,
                                   std::function<void(RecognitionJob&)> run)
    : options_(options),
      prepare_(std::move(prepare)),
      run_(std::move(run)),
      threads_{std::thread([this] { Loop(0); }), std::thread([this] { Loop(1); })} {}

RecognitionQueue::~RecognitionQueue() {
  std::deque<RecognitionJob> left[2];
  {
    std::lock_guard<std::mutex> lock(mu_);
    stopping_ = true;
    left[0].swap(jobs_[0]);
    left[1].swap(jobs_[1]);
  }
  cv_.notify_all();
  for (std::thread& t : threads_) t.join();
  for (std::deque<RecognitionJob>& jobs : left) {
    for (RecognitionJob& job : jobs) {
      if (job.done) job.done();
    }
  }
}

std::function<void()> RecognitionQueue::EnqueueLocked(int step, RecognitionJob job) {
  if (stopping_) return std::move(job.done);
  std::function<void()> dropped;
  if (!options_.every_frame && !jobs_[step].empty()) {
    dropped = std::move(jobs_[step].front().done);
    jobs_[step].clear();
    skipped_.fetch_add(1, std::memory_order_relaxed);
  }
  jobs_[step].push_back(std::move(job));
  return dropped;
}

void RecognitionQueue::Offer(RecognitionJob job) {
  std::function<void()> dropped;
  {
    std::lock_guard<std::mutex> lock(mu_);
    dropped = EnqueueLocked(0, std::move(job));
  }
  cv_.notify_all();
  if (dropped) dropped();
}

void RecognitionQueue::Flush() {
  std::unique_lock<std::mutex> lock(mu_);
  cv_.wait(lock, [this] {
    return stopping_ || (jobs_[0].empty() && jobs_[1].empty() && !running_[0] && !running_[1]);
  });
}

void RecognitionQueue::Loop(int step) {
  SetThreadNice(options_.nice);
  for (;;) {
    RecognitionJob job;
    {
      std::unique_lock<std::mutex> lock(mu_);
      // Newest: a frame is prepared only once no prepared one waits, so the preparing
      // step never burns a core on frames the running step would skip.
      cv_.wait(lock, [&] {
        return stopping_ ||
               (!jobs_[step].empty() && (step == 1 || options_.every_frame || jobs_[1].empty()));
      });
      if (stopping_) return;
      job = std::move(jobs_[step].front());
      jobs_[step].pop_front();
      running_[step] = true;
    }
    if (step == 1) cv_.notify_all();  // the waiting slot is free: step 0 may prepare
    if (step == 0) {
      prepare_(job);
      std::function<void()> dropped;
      {
        std::lock_guard<std::mutex> lock(mu_);
        running_[0] = false;
        dropped = EnqueueLocked(1, std::move(job));
      }
      cv_.notify_all();
      if (dropped) dropped();
    } else {
      run_(job);
      if (job.done) job.done();  // before the job counts as finished (Flush)
      {
        std::lock_guard<std::mutex> lock(mu_);
        running_[1] = false;
      }
      cv_.notify_all();
    }
  }
}

}  // namespace skimap::server
