// Running a command per event without blocking, and waking a blocked reader on SIGINT.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "momentum/core/error.hpp"
#include "momentum/drivers/live.hpp"

using namespace momentum::detect;
using namespace momentum::drivers;

namespace {
std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(CommandRunner, RunsWithTheEventInTheEnvironmentWithoutBlocking) {
  const std::string base = (std::filesystem::temp_directory_path() / ("momentum_cmd_" + std::to_string(::getpid()))).string();
  const std::string out = base + ".out", gate = base + ".gate";
  ASSERT_EQ(::mkfifo(gate.c_str(), 0600), 0);
  Event e;
  e.id = 4;
  e.link = 2;
  e.joints = {1, 2};
  e.t_onset_estimate = 1.25;
  e.t_detect = 1.5;
  e.peaks = {3.5, 4, 0.25};
  // The command cannot finish before the test opens the gate: launch() returning while it
  // still runs shows that launch() does not wait (if it did, this test would never end).
  CommandRunner runner("cat " + gate + " > /dev/null; echo \"$MOMENTUM_EVENT|$MOMENTUM_LINK|$MOMENTUM_JOINTS|$MOMENTUM_T_ONSET|"
                       "$MOMENTUM_T_DETECT|$MOMENTUM_PEAKS\" > " + out + "; read line; echo \"stdin:$line\" >> " + out);
  runner.launch(e);
  EXPECT_EQ(runner.running(), 1u);
  EXPECT_FALSE(std::filesystem::exists(out));
  { std::ofstream open_the_gate(gate); }
  runner.wait_all();
  EXPECT_EQ(runner.running(), 0u);
  EXPECT_EQ(runner.failures(), 0u);
  // stdin is /dev/null: `read` gets nothing.
  EXPECT_EQ(read_file(out), "4|2|1 2|1.25|1.5|3.5 4 0.25\nstdin:\n");
  std::remove(out.c_str());
  std::remove(gate.c_str());
}

TEST(CommandRunner, FailuresAreCountedAndReported) {
  std::vector<std::string> warnings;
  auto old = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  {
    CommandRunner runner("exit 3");
    Event e;
    e.id = 1;
    runner.launch(e);
    while (runner.running()) {  // reap() collects it once it has ended, however long that takes
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      runner.reap();
    }
    EXPECT_EQ(runner.running(), 0u);
    EXPECT_EQ(runner.failures(), 1u);
  }
  momentum::set_warning_sink(old);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "event 1: --on-collision command exited with status 3");
}

TEST(InterruptWatch, WakesAWaitOnAQuietPipeAtOnce) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  InterruptWatch watch;
  EXPECT_EQ(watch.signal(), 0);
  std::thread sender([] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ::kill(::getpid(), SIGINT);
  });
  EXPECT_FALSE(watch.wait_readable(fds[0]));  // nothing ever written: only the signal ends it
  sender.join();
  EXPECT_EQ(watch.signal(), SIGINT);
  ::close(fds[0]);
  ::close(fds[1]);
}

TEST(InterruptWatch, DataWakesTheWaitToo) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  InterruptWatch watch;
  ASSERT_EQ(::write(fds[1], "x", 1), 1);
  EXPECT_TRUE(watch.wait_readable(fds[0]));
  ::close(fds[1]);
  ::close(fds[0]);
}

// A burst of events cannot start a shell per event at once: at most `jobs` run, `queue` wait,
// the rest are dropped and counted (mo-detect --hook-jobs, --hook-queue).
TEST(CommandRunner, ABurstRunsBoundedQueuesAndDropsTheRest) {
  std::vector<std::string> warnings;
  auto old = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  const std::string base = (std::filesystem::temp_directory_path() / ("momentum_burst_" + std::to_string(::getpid()))).string();
  const std::string gate = base + ".gate", log = base + ".log";
  ASSERT_EQ(::mkfifo(gate.c_str(), 0600), 0);
  {
    // Every command waits at the gate, so none can end before all 20 events are in.
    CommandRunner runner("cat " + gate + " > /dev/null; echo \"$MOMENTUM_EVENT\" >> " + log, "--on-collision", 2, 3);
    for (std::uint64_t id = 1; id <= 20; ++id) {
      Event e;
      e.id = id;
      runner.launch(e);
      runner.reap();
    }
    EXPECT_EQ(runner.running(), 2u);
    EXPECT_EQ(runner.queued(), 3u);
    EXPECT_EQ(runner.dropped(), 15u);
    EXPECT_EQ(runner.launched(), 20u);
    // Open the gate for every command that waits at it, until all have run.
    std::atomic<bool> done{false};
    std::thread opener([&] {
      while (!done) {
        const int w = ::open(gate.c_str(), O_WRONLY | O_NONBLOCK);  // fails while no reader waits
        if (w >= 0) ::close(w);
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    });
    runner.wait_all();
    done = true;
    opener.join();
    std::remove(gate.c_str());
    EXPECT_EQ(runner.most_running(), 2u);
    EXPECT_EQ(runner.failures(), 0u);
    EXPECT_EQ(runner.report(),
              "--on-collision: 15 of 20 commands dropped (queue full: 2 running, 3 waiting)");
  }
  momentum::set_warning_sink(old);
  // The five that ran are the first five events, in order of their start.
  std::istringstream ran(read_file(log));
  std::vector<int> ids;
  for (int id; ran >> id;) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<int>{1, 2, 3, 4, 5}));
  ASSERT_EQ(warnings.size(), 1u);  // the first drop only
  EXPECT_EQ(warnings[0], "event 6: --on-collision command dropped: 2 running and 3 waiting (more drops are counted)");
  std::remove(log.c_str());
}

// Failing commands: the first five warned, then one line at the end.
TEST(CommandRunner, FailureWarningsAreCapped) {
  std::vector<std::string> warnings;
  auto old = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  std::string report;
  {
    CommandRunner runner("exit 7", "--on-contact", 3, 100);
    for (std::uint64_t id = 1; id <= 12; ++id) {
      Event e;
      e.id = id;
      runner.launch(e);
    }
    runner.wait_all();
    EXPECT_EQ(runner.failures(), 12u);
    EXPECT_EQ(runner.dropped(), 0u);
    EXPECT_LE(runner.most_running(), 3u);
    report = runner.report();
  }
  momentum::set_warning_sink(old);
  ASSERT_EQ(warnings.size(), CommandRunner::kWarned);
  for (const auto& w : warnings) EXPECT_NE(w.find(": --on-contact command exited with status 7"), std::string::npos) << w;
  EXPECT_EQ(report, "--on-contact: 12 of 12 commands failed (7 not shown)");
}

// mo-detect --stall: a wait on a quiet pipe gives up after its time, without a signal.
TEST(InterruptWatch, AWaitWithATimeoutEndsOnAQuietPipe) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  InterruptWatch watch;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(watch.wait_readable(fds[0], 50), -1);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(50));
  ASSERT_EQ(::write(fds[1], "x", 1), 1);
  EXPECT_EQ(watch.wait_readable(fds[0], 50), 1);
  ::close(fds[1]);
  ::close(fds[0]);
}
