// For ThreadSanitizer builds only (deploy/test.sh's tsan stage): tells TSan
// about the synchronisation inside Debian's Abseil.
//
// Debian's libabsl_synchronization is built without TSan, so TSan cannot
// see absl::Mutex, absl::CondVar or absl::Notification order anything:
// every access guarded by an absl::Mutex would be reported as a race. This
// file defines the same functions in the test executable, which the dynamic
// linker then binds in place of the library's (in the library's own calls
// too, made through its PLT); each calls the library's version (dlsym with
// RTLD_NEXT) and adds the happens-before edge TSan needs: a release on the
// object before it is unlocked or notified, an acquire after it is locked
// or waited for. A Condition is evaluated by the library while it holds the
// lock, on the waiter's thread or on the thread that unlocks, so each
// evaluation is wrapped in an acquire and a release of the mutex too.
// Linked with -rdynamic, so that the library binds to them.
//
// Abseil's deadlock detector keeps a graph of lock orders in memory that
// its own (uninstrumented) spin lock guards; TSan sees those accesses
// through its memmove interceptor and would report them, so the detector
// is off in this build (TSan detects lock-order inversions itself).
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>

#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"
#include "absl/time/time.h"

extern "C" {
void __tsan_acquire(void* addr);
void __tsan_release(void* addr);
}

namespace {

// The library's definition of the symbol `mangled`, as a function pointer.
template <typename Fn>
Fn Real(const char* mangled) {
  void* fn = dlsym(RTLD_NEXT, mangled);
  if (fn == nullptr) {
    std::fprintf(stderr, "tsan_absl_sync: %s not found: %s\n", mangled, dlerror());
    std::abort();
  }
  return reinterpret_cast<Fn>(fn);
}

void Acquire(const void* p) { __tsan_acquire(const_cast<void*>(p)); }
void Release(const void* p) { __tsan_release(const_cast<void*>(p)); }

// `inner` evaluated under `mu`, as the library evaluates it: with the lock
// held, perhaps on another thread.
struct LockedCondition {
  const absl::Condition* inner;
  const absl::Mutex* mu;
  static bool Eval(LockedCondition* c) {
    Acquire(c->mu);
    const bool met = c->inner->Eval();
    Release(c->mu);
    return met;
  }
};

const bool kDeadlockDetectionOff = [] {
  absl::SetMutexDeadlockDetectionMode(absl::OnDeadlockCycle::kIgnore);
  return true;
}();

// Notification's flag is read inline (HasBeenNotified) as an atomic with
// acquire order: the release must be on the flag's address too.
const void* NotifiedFlag(const absl::Notification* n) {
  static_assert(sizeof(absl::Notification) == 2 * sizeof(void*));
  return reinterpret_cast<const char*>(n) + sizeof(void*);
}

}  // namespace

// The functions below are the library's own, with the same signatures; the
// mangled names are those of Debian's inline namespace (absl::debian3).
#define OAIPP_REAL(type, name) static const auto real = Real<type>(name)

namespace absl {
ABSL_NAMESPACE_BEGIN

void Mutex::Lock() {
  OAIPP_REAL(void (*)(Mutex*), "_ZN4absl7debian35Mutex4LockEv");
  real(this);
  Acquire(this);
}
void Mutex::ReaderLock() {
  OAIPP_REAL(void (*)(Mutex*), "_ZN4absl7debian35Mutex10ReaderLockEv");
  real(this);
  Acquire(this);
}
bool Mutex::TryLock() {
  OAIPP_REAL(bool (*)(Mutex*), "_ZN4absl7debian35Mutex7TryLockEv");
  const bool locked = real(this);
  if (locked) Acquire(this);
  return locked;
}
bool Mutex::ReaderTryLock() {
  OAIPP_REAL(bool (*)(Mutex*), "_ZN4absl7debian35Mutex13ReaderTryLockEv");
  const bool locked = real(this);
  if (locked) Acquire(this);
  return locked;
}
void Mutex::Unlock() {
  OAIPP_REAL(void (*)(Mutex*), "_ZN4absl7debian35Mutex6UnlockEv");
  Release(this);
  real(this);
}
void Mutex::ReaderUnlock() {
  OAIPP_REAL(void (*)(Mutex*), "_ZN4absl7debian35Mutex12ReaderUnlockEv");
  Release(this);
  real(this);
}
void Mutex::LockWhen(const Condition& cond) {
  OAIPP_REAL(void (*)(Mutex*, const Condition&),
             "_ZN4absl7debian35Mutex8LockWhenERKNS0_9ConditionE");
  LockedCondition locked{&cond, this};
  real(this, Condition(&LockedCondition::Eval, &locked));
  Acquire(this);
}
void Mutex::ReaderLockWhen(const Condition& cond) {
  OAIPP_REAL(void (*)(Mutex*, const Condition&),
             "_ZN4absl7debian35Mutex14ReaderLockWhenERKNS0_9ConditionE");
  LockedCondition locked{&cond, this};
  real(this, Condition(&LockedCondition::Eval, &locked));
  Acquire(this);
}
bool Mutex::LockWhenWithTimeout(const Condition& cond, absl::Duration timeout) {
  OAIPP_REAL(bool (*)(Mutex*, const Condition&, absl::Duration),
             "_ZN4absl7debian35Mutex19LockWhenWithTimeoutERKNS0_9ConditionENS0_8DurationE");
  LockedCondition locked{&cond, this};
  const bool met = real(this, Condition(&LockedCondition::Eval, &locked), timeout);
  Acquire(this);
  return met;
}
bool Mutex::LockWhenWithDeadline(const Condition& cond, absl::Time deadline) {
  OAIPP_REAL(bool (*)(Mutex*, const Condition&, absl::Time),
             "_ZN4absl7debian35Mutex20LockWhenWithDeadlineERKNS0_9ConditionENS0_4TimeE");
  LockedCondition locked{&cond, this};
  const bool met = real(this, Condition(&LockedCondition::Eval, &locked), deadline);
  Acquire(this);
  return met;
}
void Mutex::Await(const Condition& cond) {
  OAIPP_REAL(void (*)(Mutex*, const Condition&), "_ZN4absl7debian35Mutex5AwaitERKNS0_9ConditionE");
  LockedCondition locked{&cond, this};
  Release(this);
  real(this, Condition(&LockedCondition::Eval, &locked));
  Acquire(this);
}
bool Mutex::AwaitWithTimeout(const Condition& cond, absl::Duration timeout) {
  OAIPP_REAL(bool (*)(Mutex*, const Condition&, absl::Duration),
             "_ZN4absl7debian35Mutex16AwaitWithTimeoutERKNS0_9ConditionENS0_8DurationE");
  LockedCondition locked{&cond, this};
  Release(this);
  const bool met = real(this, Condition(&LockedCondition::Eval, &locked), timeout);
  Acquire(this);
  return met;
}
bool Mutex::AwaitWithDeadline(const Condition& cond, absl::Time deadline) {
  OAIPP_REAL(bool (*)(Mutex*, const Condition&, absl::Time),
             "_ZN4absl7debian35Mutex17AwaitWithDeadlineERKNS0_9ConditionENS0_4TimeE");
  LockedCondition locked{&cond, this};
  Release(this);
  const bool met = real(this, Condition(&LockedCondition::Eval, &locked), deadline);
  Acquire(this);
  return met;
}

void CondVar::Wait(Mutex* mu) {
  OAIPP_REAL(void (*)(CondVar*, Mutex*), "_ZN4absl7debian37CondVar4WaitEPNS0_5MutexE");
  Release(mu);
  real(this, mu);
  Acquire(mu);
}
bool CondVar::WaitWithTimeout(Mutex* mu, absl::Duration timeout) {
  OAIPP_REAL(bool (*)(CondVar*, Mutex*, absl::Duration),
             "_ZN4absl7debian37CondVar15WaitWithTimeoutEPNS0_5MutexENS0_8DurationE");
  Release(mu);
  const bool timed_out = real(this, mu, timeout);
  Acquire(mu);
  return timed_out;
}
bool CondVar::WaitWithDeadline(Mutex* mu, absl::Time deadline) {
  OAIPP_REAL(bool (*)(CondVar*, Mutex*, absl::Time),
             "_ZN4absl7debian37CondVar16WaitWithDeadlineEPNS0_5MutexENS0_4TimeE");
  Release(mu);
  const bool timed_out = real(this, mu, deadline);
  Acquire(mu);
  return timed_out;
}

void Notification::Notify() {
  OAIPP_REAL(void (*)(Notification*), "_ZN4absl7debian312Notification6NotifyEv");
  Release(this);
  Release(NotifiedFlag(this));
  real(this);
}
void Notification::WaitForNotification() const {
  OAIPP_REAL(void (*)(const Notification*),
             "_ZNK4absl7debian312Notification19WaitForNotificationEv");
  real(this);
  Acquire(this);
}
bool Notification::WaitForNotificationWithTimeout(absl::Duration timeout) const {
  OAIPP_REAL(bool (*)(const Notification*, absl::Duration),
             "_ZNK4absl7debian312Notification30WaitForNotificationWithTimeoutENS0_8DurationE");
  const bool notified = real(this, timeout);
  if (notified) Acquire(this);
  return notified;
}
bool Notification::WaitForNotificationWithDeadline(absl::Time deadline) const {
  OAIPP_REAL(bool (*)(const Notification*, absl::Time),
             "_ZNK4absl7debian312Notification31WaitForNotificationWithDeadlineENS0_4TimeE");
  const bool notified = real(this, deadline);
  if (notified) Acquire(this);
  return notified;
}

ABSL_NAMESPACE_END
}  // namespace absl
