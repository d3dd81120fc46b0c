// RecognitionQueue (server/core/recognition/recognition_queue.h): the two steps of each job, their
// overlap across jobs, the policies, Flush and the done calls on destruction.
#include "server/core/recognition/recognition_queue.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace skimap::server {
namespace {

using namespace std::chrono_literals;

RecognitionJob Job(uint64_t sequence, std::function<void()> done = nullptr) {
  RecognitionJob job;
  job.sequence = sequence;
  job.done = std::move(done);
  return job;
}

// What the steps saw, in the order they saw it.
struct Log {
  std::mutex mu;
  std::condition_variable cv;
  std::vector<uint64_t> prepared, ran, done;
  void Add(std::vector<uint64_t>* v, uint64_t s) {
    std::lock_guard<std::mutex> lock(mu);
    v->push_back(s);
    cv.notify_all();
  }
  // Waits until `v` holds n entries; false after 10 s.
  bool WaitFor(std::vector<uint64_t>* v, size_t n) {
    std::unique_lock<std::mutex> lock(mu);
    return cv.wait_for(lock, 10s, [&] { return v->size() >= n; });
  }
};

TEST(RecognitionQueueTest, EveryFrameRunsEveryJobInOrderWithItsPreparedResult) {
  Log log;
  {
    RecognitionQueue q(
        {.every_frame = true},
        [&](RecognitionJob& job) {
          recognition::LabelObservations obs;
          obs.features = static_cast<int>(job.sequence) * 10;
          job.observed = obs;
          log.Add(&log.prepared, job.sequence);
        },
        [&](RecognitionJob& job) {
          ASSERT_TRUE(job.observed.ok());
          EXPECT_EQ(job.observed->features, static_cast<int>(job.sequence) * 10);
          log.Add(&log.ran, job.sequence);
        });
    for (uint64_t s = 1; s <= 20; ++s) q.Offer(Job(s, [&log, s] { log.Add(&log.done, s); }));
    q.Flush();
    // Flush returned: every job ran and was acknowledged.
    std::lock_guard<std::mutex> lock(log.mu);
    EXPECT_EQ(log.ran.size(), 20u);
    EXPECT_EQ(log.done.size(), 20u);
  }
  std::vector<uint64_t> all(20);
  for (uint64_t s = 1; s <= 20; ++s) all[s - 1] = s;
  EXPECT_EQ(log.prepared, all);
  EXPECT_EQ(log.ran, all);
  EXPECT_EQ(log.done, all);
}

TEST(RecognitionQueueTest, TheNextJobIsPreparedWhileTheCurrentOneRuns) {
  Log log;
  bool overlapped = false;
  {
    RecognitionQueue q(
        {.every_frame = true}, [&](RecognitionJob& job) { log.Add(&log.prepared, job.sequence); },
        [&](RecognitionJob& job) {
          // Job 1's run waits for job 2's preparation: with one thread for both steps
          // this would time out.
          if (job.sequence == 1) overlapped = log.WaitFor(&log.prepared, 2);
          log.Add(&log.ran, job.sequence);
        });
    q.Offer(Job(1));
    q.Offer(Job(2));
    q.Flush();
  }
  EXPECT_TRUE(overlapped);
  EXPECT_EQ(log.ran, (std::vector<uint64_t>{1, 2}));
}

TEST(RecognitionQueueTest, NewestPreparesOnlyWhatWillRunAndAcknowledgesTheRest) {
  Log log;
  std::mutex gate_mu;
  std::condition_variable gate_cv;
  bool open = false;
  std::unique_ptr<RecognitionQueue> q = std::make_unique<RecognitionQueue>(
      RecognitionQueue::Options{.every_frame = false},
      [&](RecognitionJob& job) { log.Add(&log.prepared, job.sequence); },
      [&](RecognitionJob& job) {
        log.Add(&log.ran, job.sequence);
        std::unique_lock<std::mutex> lock(gate_mu);
        gate_cv.wait(lock, [&] { return open; });  // the run step is busy until opened
      });
  q->Offer(Job(1, [&] { log.Add(&log.done, 1); }));
  ASSERT_TRUE(log.WaitFor(&log.ran, 1));  // job 1 holds the run step
  q->Offer(Job(2, [&] { log.Add(&log.done, 2); }));
  ASSERT_TRUE(log.WaitFor(&log.prepared, 2));  // job 2 prepared: it waits for the run step
  // While a prepared job waits, nothing more is prepared: 3, 4 and 5 are replaced by the
  // next frame before any work is done on them, and 6 is the newest when the run step
  // frees.
  for (uint64_t s = 3; s <= 6; ++s) q->Offer(Job(s, [&log, s] { log.Add(&log.done, s); }));
  {
    std::lock_guard<std::mutex> lock(gate_mu);
    open = true;
  }
  gate_cv.notify_all();
  q->Flush();
  EXPECT_EQ(q->skipped(), 3u);
  q.reset();
  EXPECT_EQ(log.prepared, (std::vector<uint64_t>{1, 2, 6}));
  EXPECT_EQ(log.ran, (std::vector<uint64_t>{1, 2, 6}));
  std::vector<uint64_t> done = log.done;
  std::sort(done.begin(), done.end());
  EXPECT_EQ(done, (std::vector<uint64_t>{1, 2, 3, 4, 5, 6}));  // every job acknowledged
}

TEST(RecognitionQueueTest, DestructionAcknowledgesJobsThatNeverRan) {
  Log log;
  std::atomic<bool> release{false};
  auto q = std::make_unique<RecognitionQueue>(
      RecognitionQueue::Options{.every_frame = true},
      [&](RecognitionJob& job) {
        log.Add(&log.prepared, job.sequence);
        while (job.sequence == 1 && !release.load()) std::this_thread::sleep_for(1ms);
      },
      [&](RecognitionJob& job) { log.Add(&log.ran, job.sequence); });
  for (uint64_t s = 1; s <= 5; ++s) q->Offer(Job(s, [&log, s] { log.Add(&log.done, s); }));
  ASSERT_TRUE(log.WaitFor(&log.prepared, 1));
  std::thread stop([&] { q.reset(); });
  std::this_thread::sleep_for(20ms);  // the destructor has begun: job 1 is in `prepare`
  release = true;
  stop.join();
  std::vector<uint64_t> done = log.done;
  std::sort(done.begin(), done.end());
  EXPECT_EQ(done, (std::vector<uint64_t>{1, 2, 3, 4, 5}));
  EXPECT_TRUE(log.ran.empty() || log.ran == std::vector<uint64_t>{1});
}

}  // namespace
}  // namespace skimap::server
