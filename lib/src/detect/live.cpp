#include "momentum/detect/live.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "momentum/core/number.hpp"
#include "momentum/stream/error.hpp"

extern char** environ;

namespace momentum::detect {

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

bool InterruptWatch::wait_readable(int fd) const {
  for (;;) {
    if (g_signal.load() != 0) return false;
    struct pollfd fds[2] = {{fd, POLLIN, 0}, {g_pipe[0], POLLIN, 0}};
    const int n = ::poll(fds, 2, -1);
    if (n < 0) {
      if (errno == EINTR) continue;
      return true;  // let the read itself report the problem
    }
    if (fds[1].revents) return false;
    if (fds[0].revents) return true;
  }
}

// ---- CommandRunner ---------------------------------------------------------------------

CommandRunner::~CommandRunner() {
  try {
    wait_all();
  } catch (...) {
  }
}

void CommandRunner::launch(const Event& event) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e)
    if (std::strncmp(*e, "MOMENTUM_", 9) != 0) env.emplace_back(*e);
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
  ++launched_;
  if (rc != 0) {
    ++failures_;
    warn("event " + std::to_string(event.id) + ": cannot run --on-collision command: " + std::strerror(rc));
    return;
  }
  children_.emplace_back(pid, event.id);
}

void CommandRunner::collect(pid_t pid, int status) {
  for (auto it = children_.begin(); it != children_.end(); ++it) {
    if (it->first != pid) continue;
    const std::uint64_t id = it->second;
    children_.erase(it);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
    ++failures_;
    if (WIFEXITED(status))
      warn("event " + std::to_string(id) + ": --on-collision command exited with status " +
           std::to_string(WEXITSTATUS(status)));
    else if (WIFSIGNALED(status))
      warn("event " + std::to_string(id) + ": --on-collision command killed by signal " +
           std::to_string(WTERMSIG(status)));
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
}

void CommandRunner::wait_all() {
  while (!children_.empty()) {
    int status = 0;
    const pid_t pid = children_.front().first;
    const pid_t got = ::waitpid(pid, &status, 0);
    if (got == pid) collect(pid, status);
    else if (got < 0 && errno != EINTR) children_.erase(children_.begin());
  }
}

}  // namespace momentum::detect
