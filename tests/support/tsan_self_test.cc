// The ThreadSanitizer stage's check of itself (deploy/test.sh): with no
// argument, threads that share data only under absl::Mutex, CondVar,
// Condition and Notification must run without a report (the Abseil shim,
// tsan_absl_sync.cc, makes those visible to TSan); with "race", one
// unguarded write from two threads must be reported, so that the stage can
// fail at all.
#include <cstring>
#include <thread>
#include <vector>

#include "absl/synchronization/mutex.h"
#include "absl/synchronization/notification.h"

int main(int argc, char** argv) {
  if (argc > 1 && std::strcmp(argv[1], "race") == 0) {
    int shared = 0;
    std::thread other([&] { shared = 1; });
    shared = 2;
    other.join();
    return shared == 0 ? 1 : 0;
  }
  absl::Mutex mu;
  long sum = 0;
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 10000; ++i) {
        absl::MutexLock lock(&mu);
        ++sum;
      }
    });
  }
  for (std::thread& t : threads) t.join();

  int handed = 0;
  absl::Notification ready;
  std::thread producer([&] {
    handed = 42;
    ready.Notify();
  });
  ready.WaitForNotification();
  const int got = handed;
  producer.join();

  int queued = 0;
  bool full = false;
  std::thread filler([&] {
    absl::MutexLock lock(&mu);
    queued = 7;
    full = true;
  });
  {
    absl::MutexLock lock(&mu);
    mu.Await(absl::Condition(&full));
  }
  const int seen = queued;
  filler.join();
  return sum == 40000 && got == 42 && seen == 7 ? 0 : 1;
}
