#pragma once
// What a detector needs to run live: ending cleanly on SIGINT/SIGTERM even while blocked on a
// quiet input pipe, and running a command per event without waiting for it.

#include <sys/types.h>

#include <cstdint>
#include <exception>
#include <string>
#include <vector>

#include "momentum/detect/events.hpp"

namespace momentum::detect {

// Thrown out of a read hook when SIGINT or SIGTERM arrived; the tool closes its open event
// and exits normally.
class Interrupted : public std::exception {
 public:
  const char* what() const noexcept override { return "interrupted"; }
};

// Catches SIGINT and SIGTERM for the life of the object. The handler only records the signal
// and writes one byte to a self-pipe, so wait_readable() wakes up at once. One instance per
// process. Throws momentum::Error when the pipe cannot be created.
class InterruptWatch {
 public:
  InterruptWatch();
  ~InterruptWatch();
  InterruptWatch(const InterruptWatch&) = delete;
  InterruptWatch& operator=(const InterruptWatch&) = delete;

  // The signal number received, or 0.
  int signal() const;
  // Blocks until `fd` has data (or end of file, or an error) or a signal arrives. Returns
  // false when a signal arrived.
  bool wait_readable(int fd) const;
};

// Runs `sh -c COMMAND` per event, detached from detection: posix_spawn, stdin from /dev/null,
// stdout to our stderr, the event in MOMENTUM_* environment variables (see mo-detect(1)).
class CommandRunner {
 public:
  explicit CommandRunner(std::string command) : command_(std::move(command)) {}
  // Waits for the commands still running.
  ~CommandRunner();
  CommandRunner(const CommandRunner&) = delete;
  CommandRunner& operator=(const CommandRunner&) = delete;

  // Starts the command for `event` and returns at once. A failure to start is reported through
  // momentum::warn (detection must go on), counted in failures().
  void launch(const Event& event);
  // Collects finished commands without blocking; a non-zero status is reported through
  // momentum::warn and counted.
  void reap();
  // Waits for every command still running.
  void wait_all();
  std::size_t running() const { return children_.size(); }
  std::uint64_t launched() const { return launched_; }
  std::uint64_t failures() const { return failures_; }

 private:
  void collect(pid_t pid, int status);
  std::string command_;
  std::vector<std::pair<pid_t, std::uint64_t>> children_;  // pid, event number
  std::uint64_t launched_ = 0, failures_ = 0;
};

}  // namespace momentum::detect
