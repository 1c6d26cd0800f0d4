#pragma once
// The scheduling of a lockstep pair (the HIL harness and the firmware's loop, each waiting for
// the other's frames): SCHED_BATCH for the calling thread. A woken SCHED_BATCH thread does not
// preempt the thread that woke it (the kernel's wake-up preemption skips batch threads); in
// lockstep the waker blocks at once (it waits for the answer), so the peer runs then, after
// every frame of the batch is written. As SCHED_OTHER, the first frame of a period's batch
// woke the peer on the same CPU in the middle of the write: it read a part, slept again, and
// each period cost about three extra context switches. Only from SCHED_OTHER (a real-time
// policy asked for stays); nothing else changes (nice value, CPU time share).

#include <pthread.h>
#include <sched.h>

namespace mrd::common {

// Switches the calling thread from SCHED_OTHER to SCHED_BATCH; true when it did.
inline bool UseLockstepScheduling() {
  int policy = 0;
  sched_param sp{};
  if (pthread_getschedparam(pthread_self(), &policy, &sp) != 0 || policy != SCHED_OTHER) {
    return false;
  }
  sp.sched_priority = 0;
  return pthread_setschedparam(pthread_self(), SCHED_BATCH, &sp) == 0;
}

// SCHED_BATCH for the calling thread while it lives (when on), then SCHED_OTHER again.
class ScopedLockstepScheduling {
 public:
  explicit ScopedLockstepScheduling(bool on) : changed_(on && UseLockstepScheduling()) {}
  ~ScopedLockstepScheduling() {
    if (!changed_) return;
    sched_param sp{};
    (void)pthread_setschedparam(pthread_self(), SCHED_OTHER, &sp);
  }
  ScopedLockstepScheduling(const ScopedLockstepScheduling&) = delete;
  ScopedLockstepScheduling& operator=(const ScopedLockstepScheduling&) = delete;

 private:
  bool changed_;
};

}  // namespace mrd::common
