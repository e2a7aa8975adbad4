// Running a command per event without blocking, and waking a blocked reader on SIGINT.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "momentum/detect/live.hpp"
#include "momentum/stream/error.hpp"

using namespace momentum::detect;

namespace {
std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(CommandRunner, RunsWithTheEventInTheEnvironmentWithoutBlocking) {
  const std::string out = (std::filesystem::temp_directory_path() / ("momentum_cmd_" + std::to_string(::getpid()))).string();
  Event e;
  e.id = 4;
  e.link = 2;
  e.joints = {1, 2};
  e.t_onset_estimate = 1.25;
  e.t_detect = 1.5;
  e.peaks = {3.5, 4, 0.25};
  CommandRunner runner("sleep 0.3; echo \"$MOMENTUM_EVENT|$MOMENTUM_LINK|$MOMENTUM_JOINTS|$MOMENTUM_T_ONSET|"
                       "$MOMENTUM_T_DETECT|$MOMENTUM_PEAKS\" > " + out + "; read line; echo \"stdin:$line\" >> " + out);
  const auto start = std::chrono::steady_clock::now();
  runner.launch(e);
  const double launch_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(launch_s, 0.2);  // did not wait for the 0.3 s command
  EXPECT_EQ(runner.running(), 1u);
  runner.wait_all();
  EXPECT_EQ(runner.running(), 0u);
  EXPECT_EQ(runner.failures(), 0u);
  // stdin is /dev/null: `read` gets nothing.
  EXPECT_EQ(read_file(out), "4|2|1 2|1.25|1.5|3.5 4 0.25\nstdin:\n");
  std::remove(out.c_str());
}

TEST(CommandRunner, FailuresAreCountedAndReported) {
  std::vector<std::string> warnings;
  auto old = momentum::set_warning_sink([&](std::string_view m) { warnings.emplace_back(m); });
  {
    CommandRunner runner("exit 3");
    Event e;
    e.id = 1;
    runner.launch(e);
    for (int i = 0; i < 200 && runner.running(); ++i) {
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
