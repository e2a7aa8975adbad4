#pragma once
// What a detector needs to run live: ending cleanly on SIGINT/SIGTERM even while blocked on a
// quiet input pipe, and running a command per event without waiting for it.

#include <sys/types.h>

#include <cstdint>
#include <deque>
#include <exception>
#include <string>
#include <vector>

#include "momentum/detect/events.hpp"

namespace momentum::drivers {

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
  // The same, giving up after `timeout_ms` (>= 0): 1 when `fd` is ready, 0 when a signal
  // arrived, -1 when the time ran out.
  int wait_readable(int fd, int timeout_ms) const;
};

// Runs `sh -c COMMAND` per event, detached from detection: posix_spawn, stdin from /dev/null,
// stdout to our stderr, the event in MOMENTUM_* environment variables (see mo-detect(1)).
// Bounded: at most `jobs` commands run at once; further events wait in a queue of at most
// `queue` (started in order as running ones finish, at reap()), and an event beyond both is
// dropped and counted, so that a burst of events cannot start a shell per event at once. The
// first kWarned failures are warned one by one, the rest only counted (see report()).
class CommandRunner {
 public:
  static constexpr std::uint64_t kWarned = 5;
  // `option`: the option's name for messages ("--on-collision"). `jobs` >= 1.
  CommandRunner(std::string command, std::string option = "--on-collision", std::size_t jobs = 4,
                std::size_t queue = 64);
  // Waits for the commands still running and those queued.
  ~CommandRunner();
  CommandRunner(const CommandRunner&) = delete;
  CommandRunner& operator=(const CommandRunner&) = delete;

  // Starts (or queues) the command for `event` and returns at once. A failure to start is
  // reported through momentum::warn (detection must go on), counted in failures().
  void launch(const detect::Event& event);
  // The same with the environment given: `variables` as NAME=VALUE (MOMENTUM_* ones), and
  // `label` naming it in messages ("event 3").
  void launch(std::vector<std::string> variables, std::string label);
  // Collects finished commands without blocking, and starts queued ones in their place; a
  // non-zero status is reported through momentum::warn and counted.
  void reap();
  // Waits for every command still running or queued.
  void wait_all();
  // The end-of-run line for failures not warned and commands dropped ("" when none).
  std::string report() const;
  std::size_t running() const { return children_.size(); }
  std::size_t queued() const { return queue_.size(); }
  bool busy() const { return !children_.empty() || !queue_.empty(); }
  std::uint64_t launched() const { return launched_; }  // started or queued
  std::uint64_t failures() const { return failures_; }
  std::uint64_t dropped() const { return dropped_; }
  std::size_t most_running() const { return most_running_; }

 private:
  struct Job {
    std::vector<std::string> variables;
    std::string label;
  };
  void start(const Job& job);
  void fail(const std::string& text);
  void collect(pid_t pid, int status);
  std::string command_, option_;
  std::size_t jobs_, queue_cap_;
  std::vector<std::pair<pid_t, std::string>> children_;  // pid, label
  std::deque<Job> queue_;  // FIFO, at most queue_cap_
  std::uint64_t launched_ = 0, failures_ = 0, dropped_ = 0;
  std::size_t most_running_ = 0;
};

// The MOMENTUM_* variables of an event for a hook (mo-detect(1), ENVIRONMENT).
std::vector<std::string> event_variables(const detect::Event& event);

}  // namespace momentum::drivers
