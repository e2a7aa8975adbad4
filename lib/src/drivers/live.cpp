#include "momentum/drivers/live.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

extern char** environ;

namespace momentum::drivers {

// This driver runs the detect stage: its names are this file's vocabulary.
using namespace detect;

namespace {

std::atomic<int> g_signal{0};
int g_pipe[2] = {-1, -1};
struct sigaction g_old_int, g_old_term;

void on_signal(int number) {
  const int saved = errno;
  g_signal.store(number);
  const char byte = 1;
  [[maybe_unused]] ssize_t ignored = ::write(g_pipe[1], &byte, 1);
  errno = saved;
}

}  // namespace

InterruptWatch::InterruptWatch() {
  if (::pipe2(g_pipe, O_CLOEXEC | O_NONBLOCK) != 0)
    throw Error(std::string("cannot create a pipe: ") + std::strerror(errno));
  g_signal.store(0);
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  ::sigaction(SIGINT, &action, &g_old_int);
  ::sigaction(SIGTERM, &action, &g_old_term);
}

InterruptWatch::~InterruptWatch() {
  ::sigaction(SIGINT, &g_old_int, nullptr);
  ::sigaction(SIGTERM, &g_old_term, nullptr);
  ::close(g_pipe[0]);
  ::close(g_pipe[1]);
  g_pipe[0] = g_pipe[1] = -1;
}

int InterruptWatch::signal() const { return g_signal.load(); }

bool InterruptWatch::wait_readable(int fd) const { return wait_readable(fd, -1) != 0; }

int InterruptWatch::wait_readable(int fd, int timeout_ms) const {
  for (;;) {
    if (g_signal.load() != 0) return 0;
    struct pollfd fds[2] = {{fd, POLLIN, 0}, {g_pipe[0], POLLIN, 0}};
    // A signal's EINTR restarts the whole wait: a late reader sees a little more patience.
    const int n = ::poll(fds, 2, timeout_ms < 0 ? -1 : timeout_ms);
    if (n < 0) {
      if (errno == EINTR) continue;
      return 1;  // let the read itself report the problem
    }
    if (n == 0) return -1;
    if (fds[1].revents) return 0;
    if (fds[0].revents) return 1;
  }
}

// ---- CommandRunner ---------------------------------------------------------------------

CommandRunner::CommandRunner(std::string command, std::string option, std::size_t jobs, std::size_t queue)
    : command_(std::move(command)), option_(std::move(option)), jobs_(std::max<std::size_t>(1, jobs)), queue_cap_(queue) {}

CommandRunner::~CommandRunner() {
  try {
    wait_all();
  } catch (...) {
  }
}

std::vector<std::string> event_variables(const Event& event) {
  std::vector<std::string> env;
  std::string joints, peaks;
  for (int j : event.joints) joints += (joints.empty() ? "" : " ") + std::to_string(j);
  for (double p : event.peaks) peaks += (peaks.empty() ? "" : " ") + core::exact(p);
  env.push_back("MOMENTUM_EVENT=" + std::to_string(event.id));
  env.push_back("MOMENTUM_LINK=" + std::to_string(event.link));
  env.push_back("MOMENTUM_JOINTS=" + joints);
  env.push_back("MOMENTUM_T_ONSET=" + core::exact(event.t_onset_estimate));
  env.push_back("MOMENTUM_T_DETECT=" + core::exact(event.t_detect));
  env.push_back("MOMENTUM_PEAKS=" + peaks);
  // What identification found by then (empty when unknown).
  auto known = [](double v) { return std::isnan(v) ? std::string() : core::exact(v); };
  env.push_back("MOMENTUM_CLASS=" + event.contact.event_class);
  env.push_back("MOMENTUM_FORCE=" + known(event.contact.force));
  env.push_back("MOMENTUM_POINT=" + (std::isnan(event.contact.px) ? std::string()
                                                                   : core::exact(event.contact.px) + " " +
                                                                         core::exact(event.contact.py) + " " +
                                                                         core::exact(event.contact.pz)));
  return env;
}

void CommandRunner::launch(const Event& event) { launch(event_variables(event), "event " + std::to_string(event.id)); }

void CommandRunner::launch(std::vector<std::string> variables, std::string label) {
  ++launched_;
  if (children_.size() < jobs_ && queue_.empty()) {
    start(Job{std::move(variables), std::move(label)});
  } else if (queue_.size() < queue_cap_) {
    queue_.push_back(Job{std::move(variables), std::move(label)});
  } else {
    // Detection must not wait for its hooks: past the queue, events go without a command.
    if (dropped_++ == 0)
      warn(label + ": " + option_ + " command dropped: " + std::to_string(jobs_) + " running and " +
           std::to_string(queue_cap_) + " waiting (more drops are counted)");
  }
}

void CommandRunner::fail(const std::string& text) {
  if (++failures_ <= kWarned) warn(text);
}

void CommandRunner::start(const Job& job) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e)
    if (std::strncmp(*e, "MOMENTUM_", 9) != 0) env.emplace_back(*e);
  env.insert(env.end(), job.variables.begin(), job.variables.end());
  std::vector<char*> envp;
  for (auto& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::string sh = "/bin/sh", dash_c = "-c";
  char* argv[] = {sh.data(), dash_c.data(), command_.data(), nullptr};

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, STDERR_FILENO, STDOUT_FILENO);
  // The child must not inherit our SIGINT/SIGTERM handlers' ignored state or mask.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t defaults;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGPIPE);
  sigaddset(&defaults, SIGINT);
  sigaddset(&defaults, SIGTERM);
  posix_spawnattr_setsigdefault(&attributes, &defaults);
  sigset_t empty;
  sigemptyset(&empty);
  posix_spawnattr_setsigmask(&attributes, &empty);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
  pid_t pid = -1;
  const int rc = ::posix_spawn(&pid, "/bin/sh", &actions, &attributes, argv, envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  if (rc != 0) {
    fail(job.label + ": cannot run " + option_ + " command: " + std::strerror(rc));
    return;
  }
  children_.emplace_back(pid, job.label);
  most_running_ = std::max(most_running_, children_.size());
}

void CommandRunner::collect(pid_t pid, int status) {
  for (auto it = children_.begin(); it != children_.end(); ++it) {
    if (it->first != pid) continue;
    const std::string label = std::move(it->second);
    children_.erase(it);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
    if (WIFEXITED(status))
      fail(label + ": " + option_ + " command exited with status " + std::to_string(WEXITSTATUS(status)));
    else if (WIFSIGNALED(status))
      fail(label + ": " + option_ + " command killed by signal " + std::to_string(WTERMSIG(status)));
    else
      fail(label + ": " + option_ + " command failed");
    return;
  }
}

void CommandRunner::reap() {
  for (std::size_t i = 0; i < children_.size();) {
    int status = 0;
    const pid_t pid = children_[i].first;
    const pid_t got = ::waitpid(pid, &status, WNOHANG);
    if (got == pid) {
      collect(pid, status);  // erases entry i
    } else if (got < 0 && errno != EINTR) {
      children_.erase(children_.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      ++i;
    }
  }
  while (!queue_.empty() && children_.size() < jobs_) {
    const Job job = std::move(queue_.front());
    queue_.pop_front();
    start(job);
  }
}

void CommandRunner::wait_all() {
  while (busy()) {
    if (children_.empty()) {
      reap();  // starts queued ones
      continue;
    }
    int status = 0;
    const pid_t pid = children_.front().first;
    const pid_t got = ::waitpid(pid, &status, 0);
    if (got == pid) collect(pid, status);
    else if (got < 0 && errno != EINTR) children_.erase(children_.begin());
    reap();
  }
}

std::string CommandRunner::report() const {
  std::string text;
  if (failures_ > kWarned)
    text += option_ + ": " + std::to_string(failures_) + " of " + std::to_string(launched_ - dropped_) +
            " commands failed (" + std::to_string(failures_ - kWarned) + " not shown)";
  if (dropped_ > 0)
    text += (text.empty() ? "" : "; ") + option_ + ": " + std::to_string(dropped_) + " of " +
            std::to_string(launched_) + " commands dropped (queue full: " + std::to_string(jobs_) +
            " running, " + std::to_string(queue_cap_) + " waiting)";
  return text;
}

}  // namespace momentum::drivers
