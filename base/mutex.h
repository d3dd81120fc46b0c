// Mutex, MutexLock, CondVar: std::mutex and std::condition_variable as capabilities that
// clang's thread-safety analysis checks (-Wthread-safety, the asan build of
// scripts/build.sh), so that ABSL_GUARDED_BY(mu_) on a field guarded by a plain mutex is
// enforced, not a comment. std::mutex underneath, so ThreadSanitizer sees every
// happens-before edge (Debian's absl::Mutex is not TSan-instrumented; see rw_lock.h).
//
//   Mutex mu_;
//   CondVar cv_;
//   int pending_ ABSL_GUARDED_BY(mu_) = 0;
//   { MutexLock lock(&mu_); while (pending_ > 0) cv_.Wait(&mu_); }
//
// Waits take no predicate: a lambda is analysed on its own, outside the lock, so callers
// loop on the condition themselves (as above).
//
// Thread safety: thread safe (these are the synchronization). Not recursive.
#ifndef BASE_MUTEX_H_
#define BASE_MUTEX_H_

#include <chrono>
#include <condition_variable>
#include <mutex>

#include "absl/base/thread_annotations.h"

namespace skimap {

class ABSL_LOCKABLE Mutex {
 public:
  Mutex() = default;
  Mutex(const Mutex&) = delete;
  Mutex& operator=(const Mutex&) = delete;

  void Lock() ABSL_EXCLUSIVE_LOCK_FUNCTION() { mu_.lock(); }
  void Unlock() ABSL_UNLOCK_FUNCTION() { mu_.unlock(); }

 private:
  friend class CondVar;
  std::mutex mu_;
};

// Holds a Mutex for its scope; Unlock() / Lock() release and retake it inside the scope
// (for calls that must run unlocked).
class ABSL_SCOPED_LOCKABLE MutexLock {
 public:
  explicit MutexLock(Mutex* mu) ABSL_EXCLUSIVE_LOCK_FUNCTION(mu) : mu_(mu) { mu_->Lock(); }
  ~MutexLock() ABSL_UNLOCK_FUNCTION() {
    if (held_) mu_->Unlock();
  }
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  // REQUIRES: held.
  void Unlock() ABSL_UNLOCK_FUNCTION() {
    held_ = false;
    mu_->Unlock();
  }
  // REQUIRES: released by Unlock().
  void Lock() ABSL_EXCLUSIVE_LOCK_FUNCTION() {
    mu_->Lock();
    held_ = true;
  }

 private:
  Mutex* mu_;
  bool held_ = true;
};

// A condition variable for Mutex. Wakes may be spurious: wait in a loop on the condition.
class CondVar {
 public:
  // Releases *mu, waits for a signal, retakes *mu.
  void Wait(Mutex* mu) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu) {
    std::unique_lock<std::mutex> lock(mu->mu_, std::adopt_lock);
    cv_.wait(lock);
    lock.release();
  }
  // As Wait, until `deadline` at the latest. False if the deadline passed.
  template <class Clock, class Duration>
  bool WaitUntil(Mutex* mu, std::chrono::time_point<Clock, Duration> deadline)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu) {
    std::unique_lock<std::mutex> lock(mu->mu_, std::adopt_lock);
    const bool signalled = cv_.wait_until(lock, deadline) == std::cv_status::no_timeout;
    lock.release();
    return signalled;
  }
  void Signal() { cv_.notify_one(); }
  void SignalAll() { cv_.notify_all(); }

 private:
  std::condition_variable cv_;
};

}  // namespace skimap

#endif  // BASE_MUTEX_H_
