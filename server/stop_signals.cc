#include "server/stop_signals.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace oaipp::server {
namespace {

constexpr int kSignals[] = {SIGTERM, SIGINT};

// The pipe's write end while a StopSignals is installed, -1 otherwise.
std::atomic<int> g_write_fd{-1};

// Async-signal-safe: one write(2) of one byte, errno preserved.
void OnSignal(int signal) {
  const int saved = errno;
  const int fd = g_write_fd.load(std::memory_order_relaxed);
  if (fd >= 0) {
    const unsigned char byte = static_cast<unsigned char>(signal);
    (void)!write(fd, &byte, 1);
  }
  errno = saved;
}

void RestoreDefaults() {
  for (int signal : kSignals) std::signal(signal, SIG_DFL);
}

}  // namespace

absl::StatusOr<StopSignals> StopSignals::Install() {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    return absl::InternalError(absl::StrCat("stop signals: pipe: ", std::strerror(errno)));
  }
  // The handler must never block: a full pipe drops the byte, and one byte
  // already waiting is enough to stop.
  (void)fcntl(fds[1], F_SETFL, O_NONBLOCK);
  int expected = -1;
  if (!g_write_fd.compare_exchange_strong(expected, fds[1])) {
    close(fds[0]);
    close(fds[1]);
    return absl::FailedPreconditionError("stop signals: already installed");
  }
  struct sigaction action {};
  action.sa_handler = OnSignal;
  action.sa_flags = SA_RESTART;
  sigemptyset(&action.sa_mask);
  for (int signal : kSignals) {
    if (sigaction(signal, &action, nullptr) != 0) {
      const int error = errno;
      RestoreDefaults();
      g_write_fd.store(-1);
      close(fds[0]);
      close(fds[1]);
      return absl::InternalError(absl::StrCat("stop signals: sigaction: ", std::strerror(error)));
    }
  }
  // A mask inherited from a parent (a shell's, a test runner's) would keep
  // the signals from ever reaching the handler on this thread.
  sigset_t unblock;
  sigemptyset(&unblock);
  for (int signal : kSignals) sigaddset(&unblock, signal);
  pthread_sigmask(SIG_UNBLOCK, &unblock, nullptr);
  return StopSignals(fds[0], fds[1]);
}

StopSignals::StopSignals(StopSignals&& other) noexcept
    : read_fd_(other.read_fd_), write_fd_(other.write_fd_) {
  other.read_fd_ = -1;
  other.write_fd_ = -1;
}

StopSignals::~StopSignals() {
  if (write_fd_ < 0) return;  // moved from
  RestoreDefaults();
  g_write_fd.store(-1);
  close(read_fd_);
  close(write_fd_);
}

int StopSignals::Wait() {
  unsigned char byte = 0;
  while (true) {
    const ssize_t n = read(read_fd_, &byte, 1);
    if (n == 1) return byte;
    if (n < 0 && errno == EINTR) continue;
    // The write end is ours and open, so read() cannot see EOF; any other
    // error means the pipe is unusable: stop as if asked to.
    return SIGTERM;
  }
}

}  // namespace oaipp::server
