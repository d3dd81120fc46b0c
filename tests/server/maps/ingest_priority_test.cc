// Ingestion threads run at MapService::Options::ingest_nice (skimapd --ingest_nice), so
// that queries keep a core when frames saturate the machine (docs/operations.md,
// "Scheduling and memory"); the primitives: ThreadPool and WorkQueue workers at their nice.
#include <dirent.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <future>
#include <sstream>
#include <string>
#include <thread>

#include "base/thread_pool.h"
#include "server/core/common/work_queue.h"
#include "server/core/maps/map_service.h"
#include "server/core/recognition/recognition_queue.h"

namespace skimap::server {
namespace {

int ThisThreadNice() { return getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))); }

// Live threads of this process at niceness `nice` (field 19 of /proc/self/task/*/stat).
// A thread that is exiting may still be listed, with an empty stat or in state Z/X, for a
// moment after join() returned: it is not counted.
int ThreadsAtNice(int nice) {
  int count = 0;
  DIR* dir = opendir("/proc/self/task");
  if (dir == nullptr) return -1;
  while (dirent* e = readdir(dir)) {
    if (e->d_name[0] == '.') continue;
    std::ifstream in(std::string("/proc/self/task/") + e->d_name + "/stat");
    std::string stat((std::istreambuf_iterator<char>(in)), {});
    // Fields after the command (in parentheses, may hold spaces): state is field 3.
    const size_t paren = stat.rfind(')');
    if (paren == std::string::npos || paren + 2 >= stat.size()) continue;  // gone meanwhile
    std::istringstream rest(stat.substr(paren + 2));
    std::string field;
    for (int i = 3; i <= 19 && rest >> field; ++i) {
      if (i == 3 && (field == "Z" || field == "X")) break;
      if (i == 19 && std::stoi(field) == nice) ++count;
    }
  }
  closedir(dir);
  return count;
}

// ThreadsAtNice(nice) once it has settled at `want`, or its last value after ~5 s.
int ThreadsAtNiceSettled(int nice, int want) {
  int count = ThreadsAtNice(nice);
  for (int i = 0; i < 500 && count != want; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    count = ThreadsAtNice(nice);
  }
  return count;
}

TEST(IngestPriorityTest, PoolAndQueueWorkersRunAtTheirNiceAndCallersDoNot) {
  const int before = ThisThreadNice();
  ThreadPool pool(1, 7);
  const std::thread::id caller = std::this_thread::get_id();
  std::promise<int> worker;
  std::atomic<bool> worker_ran{false};
  pool.ParallelFor(pool.pieces(), [&](size_t, size_t) {
    if (std::this_thread::get_id() != caller) {
      if (!worker_ran.exchange(true)) worker.set_value(ThisThreadNice());
      return;
    }
    // The caller leaves the ranges to the worker until it has run one (ranges are claimed
    // one at a time by whichever thread is free).
    for (int i = 0; i < 20000 && !worker_ran.load(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  std::future<int> nice = worker.get_future();
  ASSERT_EQ(nice.wait_for(std::chrono::seconds(0)), std::future_status::ready);
  EXPECT_EQ(nice.get(), 7);
  EXPECT_EQ(ThisThreadNice(), before);
  WorkQueue queue({.capacity = 4, .nice = 9});
  EXPECT_EQ(queue.Run([] { return ThisThreadNice(); }), 9);
  WorkQueue plain({.capacity = 4});
  EXPECT_EQ(plain.Run([] { return ThisThreadNice(); }), before);
}

TEST(IngestPriorityTest, MapServiceRunsItsIngestionThreadsAtIngestNice) {
  ASSERT_EQ(ThreadsAtNiceSettled(13, 0), 0);
  MapService service({.worker_threads = 2, .ingest_nice = 13});
  v1::CreateMapRequest request;
  request.set_map_id("m");
  ASSERT_TRUE(service.CreateMap(request).ok());
  // The pool's 2 workers, the 2 decoders and the map's worker: each sets its niceness as
  // it starts, so the count gets there shortly after (slower under sanitizers).
  EXPECT_EQ(ThreadsAtNiceSettled(13, 5), 5);
}

TEST(IngestPriorityTest, RecognitionUnderNewestRunsNicerThanIngestion) {
  // NEWEST: 10 steps below ingestion (skimapd's default 5 gives 15), at most 19;
  // EVERY_FRAME: at 0, since acks wait for it.
  EXPECT_EQ(RecognitionNice(false, 5), 15);
  EXPECT_EQ(RecognitionNice(false, 0), 10);
  EXPECT_EQ(RecognitionNice(false, 12), 19);
  EXPECT_EQ(RecognitionNice(true, 5), 0);
  // The queue's two threads (prepare and run) take it.
  ASSERT_EQ(ThreadsAtNiceSettled(17, 0), 0);
  std::promise<int> prepared, ran;
  {
    RecognitionQueue queue(
        {.every_frame = true, .nice = RecognitionNice(false, 7)},
        [&](RecognitionJob&) { prepared.set_value(ThisThreadNice()); },
        [&](RecognitionJob&) { ran.set_value(ThisThreadNice()); });
    RecognitionJob job;
    job.sequence = 1;
    queue.Offer(std::move(job));
    EXPECT_EQ(prepared.get_future().get(), 17);
    EXPECT_EQ(ran.get_future().get(), 17);
  }
  // Gone with the queue (a joined thread can stay listed for a moment as it exits).
  EXPECT_EQ(ThreadsAtNiceSettled(17, 0), 0);
}

}  // namespace
}  // namespace skimap::server
