// ThreadPool (base/thread_pool.h): ParallelFor covers [0, n) exactly once in at most
// pieces() contiguous ranges, a range held up on one thread leaves the others to the rest,
// back-to-back and concurrent calls never run a finished call's function. Run under
// ThreadSanitizer by scripts/test.sh (label "concurrency").
#include "base/thread_pool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <utility>
#include <vector>

#include "base/mutex.h"

namespace skimap {
namespace {

// The ranges ParallelFor passed, sorted.
std::vector<std::pair<size_t, size_t>> Ranges(ThreadPool& pool, size_t n) {
  Mutex mu;
  std::vector<std::pair<size_t, size_t>> ranges;
  pool.ParallelFor(n, [&](size_t begin, size_t end) {
    MutexLock lock(&mu);
    ranges.emplace_back(begin, end);
  });
  std::sort(ranges.begin(), ranges.end());
  return ranges;
}

TEST(ThreadPoolTest, CoversEveryIndexOnceInAtMostPiecesRanges) {
  for (const int workers : {0, 1, 2, 3}) {
    ThreadPool pool(workers);
    EXPECT_EQ(pool.pieces(), workers == 0 ? 1u : 4u * (workers + 1));
    for (const size_t n : {1, 2, 3, 7, 8, 13, 100, 1000}) {
      const std::vector<std::pair<size_t, size_t>> ranges = Ranges(pool, n);
      ASSERT_FALSE(ranges.empty());
      EXPECT_LE(ranges.size(), std::max<size_t>(1, std::min(n, pool.pieces())));
      size_t next = 0;
      for (const auto& [begin, end] : ranges) {
        EXPECT_EQ(begin, next) << workers << " workers, n = " << n;
        EXPECT_LT(begin, end);
        next = end;
      }
      EXPECT_EQ(next, n);
    }
    EXPECT_TRUE(Ranges(pool, 0).empty());
  }
}

TEST(ThreadPoolTest, ARangeHeldUpLeavesTheOtherRangesToTheOtherThread) {
  // One worker and the caller; the first range to start waits until every other range has
  // run. With the work cut in halves, one per thread, half of it would wait for the held
  // range; claimed a range at a time, the other thread takes all of it.
  ThreadPool pool(1);
  const size_t n = pool.pieces();
  std::atomic<size_t> done{0};
  std::atomic<bool> held{false}, waited_out{false};
  pool.ParallelFor(n, [&](size_t begin, size_t end) {
    if (!held.exchange(true)) {
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
      while (done.load() < n - 1 && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
      waited_out = done.load() < n - 1;
    }
    done += end - begin;
  });
  EXPECT_FALSE(waited_out.load()) << "the other thread left ranges to the held one";
  EXPECT_EQ(done.load(), n);
}

TEST(ThreadPoolTest, BackToBackAndConcurrentCallsRunOnlyTheirOwnFunction) {
  ThreadPool pool(3);
  // Each call's function lives on the caller's stack and is gone when the call returns: a
  // worker that woke late and ran it would write a dead counter (ASan, TSan) or miscount.
  auto calls = [&](int count, std::atomic<size_t>* total) {
    for (int i = 0; i < count; ++i) {
      std::atomic<size_t> covered{0};
      pool.ParallelFor(64, [&](size_t begin, size_t end) { covered += end - begin; });
      ASSERT_EQ(covered.load(), 64u);
      *total += covered.load();
    }
  };
  std::atomic<size_t> a{0}, b{0};
  std::thread other([&] { calls(2000, &b); });
  calls(2000, &a);
  other.join();
  EXPECT_EQ(a.load(), 2000u * 64);
  EXPECT_EQ(b.load(), 2000u * 64);
}

}  // namespace
}  // namespace skimap
