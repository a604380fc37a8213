// SIGTERM and SIGINT as an event a thread can wait for, whichever thread of
// the process the kernel delivers them to.
//
// Blocking the signals and calling sigwait() only works when every thread
// blocks them, and a library can start threads before main() runs: Debian's
// pthreads OpenBLAS, loaded with the program through OpenCV's and pagmo2's
// LAPACK, starts its pool in its constructor when OPENBLAS_CORETYPE is set
// in the environment. Such a thread inherits no mask of ours, and a SIGTERM
// that lands on it kills the process at once. A handler, unlike a mask, is
// process-wide: it runs on whichever thread receives the signal and only
// writes the signal's number to a pipe, which Wait() reads.
//
//   absl::StatusOr<StopSignals> stop = StopSignals::Install();
//   ...
//   const int signal = stop->Wait();  // blocks until SIGTERM or SIGINT
#pragma once

#include "absl/status/statusor.h"

namespace oaipp::server {

class StopSignals {
 public:
  // Installs the handlers (SA_RESTART, so interrupted system calls resume).
  // At most one StopSignals is installed at a time; a second Install, or a
  // failed pipe() or sigaction(), returns an error and installs nothing.
  [[nodiscard]] static absl::StatusOr<StopSignals> Install();

  StopSignals(StopSignals&& other) noexcept;
  StopSignals& operator=(StopSignals&&) = delete;
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  // Restores the default dispositions and closes the pipe.
  ~StopSignals();

  // Blocks until SIGTERM or SIGINT arrives (or has arrived since Install)
  // and returns its number.
  [[nodiscard]] int Wait();

 private:
  StopSignals(int read_fd, int write_fd) : read_fd_(read_fd), write_fd_(write_fd) {}
  int read_fd_ = -1;
  int write_fd_ = -1;
};

}  // namespace oaipp::server
