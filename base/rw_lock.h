// RwLock: a writer-preferring reader/writer lock with Clang thread-safety annotations.
//
// Why not absl::Mutex: Debian's Abseil is built without ThreadSanitizer instrumentation,
// so TSan cannot see absl::Mutex's happens-before edges and reports false races. This
// wraps pthread_rwlock_t (intercepted by TSan) configured to prefer writers, so a stream
// of readers cannot starve the integration thread.
//
//   RwLock mu;
//   int value ABSL_GUARDED_BY(mu);
//   { WriterLock l(&mu); value = 1; }
//   { ReaderLock l(&mu); use(value); }
//
// Thread safety: thread safe (it is the lock). Not recursive.
#ifndef BASE_RW_LOCK_H_
#define BASE_RW_LOCK_H_

#include <pthread.h>

#include "absl/base/thread_annotations.h"

namespace skimap {

class ABSL_LOCKABLE RwLock {
 public:
  RwLock() {
    pthread_rwlockattr_t attr;
    pthread_rwlockattr_init(&attr);
    pthread_rwlockattr_setkind_np(&attr, PTHREAD_RWLOCK_PREFER_WRITER_NONRECURSIVE_NP);
    pthread_rwlock_init(&lock_, &attr);
    pthread_rwlockattr_destroy(&attr);
  }
  ~RwLock() { pthread_rwlock_destroy(&lock_); }
  RwLock(const RwLock&) = delete;
  RwLock& operator=(const RwLock&) = delete;

  void Lock() ABSL_EXCLUSIVE_LOCK_FUNCTION() { pthread_rwlock_wrlock(&lock_); }
  void Unlock() ABSL_UNLOCK_FUNCTION() { pthread_rwlock_unlock(&lock_); }
  void ReaderLock() ABSL_SHARED_LOCK_FUNCTION() { pthread_rwlock_rdlock(&lock_); }
  void ReaderUnlock() ABSL_UNLOCK_FUNCTION() { pthread_rwlock_unlock(&lock_); }

 private:
  pthread_rwlock_t lock_;
};

// Holds an RwLock exclusively for its scope.
class ABSL_SCOPED_LOCKABLE WriterLock {
 public:
  explicit WriterLock(RwLock* mu) ABSL_EXCLUSIVE_LOCK_FUNCTION(mu) : mu_(mu) { mu_->Lock(); }
  ~WriterLock() ABSL_UNLOCK_FUNCTION() { mu_->Unlock(); }
  WriterLock(const WriterLock&) = delete;
  WriterLock& operator=(const WriterLock&) = delete;

 private:
  RwLock* mu_;
};

// Holds an RwLock in shared mode for its scope.
class ABSL_SCOPED_LOCKABLE ReaderLock {
 public:
  explicit ReaderLock(RwLock* mu) ABSL_SHARED_LOCK_FUNCTION(mu) : mu_(mu) { mu_->ReaderLock(); }
  ~ReaderLock() ABSL_UNLOCK_FUNCTION() { mu_->ReaderUnlock(); }
  ReaderLock(const ReaderLock&) = delete;
  ReaderLock& operator=(const ReaderLock&) = delete;

 private:
  RwLock* mu_;
};

}  // namespace skimap

#endif  // BASE_RW_LOCK_H_
