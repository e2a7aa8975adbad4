// Files replaced safely: symlinks followed, devices and read-only files refused, the mode kept,
// no temporary left behind (also when a signal ends the run), and a lock that makes a
// read-compare-write see the previous holder's write.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <functional>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"

namespace fs = std::filesystem;
using momentum::core::BrokenPipe;
using momentum::core::FileLock;
using momentum::core::is_standard_output;
using momentum::core::OutputFile;
using momentum::core::write_document;
using momentum::core::RemoveOnSignal;
using momentum::core::replace_file;
using momentum::core::write_target;

namespace {

struct Folder {
  fs::path path;
  Folder() {
    path = fs::path(::testing::TempDir()) / ("momentum_core_file_" + std::to_string(::getpid()) + "_" +
                                              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Folder() { fs::remove_all(path); }
  // Files in the folder other than those named.
  std::size_t entries() const { return static_cast<std::size_t>(std::distance(fs::directory_iterator(path), {})); }
};

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

}  // namespace

TEST(ReplaceFile, WritesANewFileWithTheDefaultModeAndLeavesNoTemporary) {
  Folder dir;
  const fs::path p = dir.path / "new.json";
  replace_file(p, "{}\n");
  EXPECT_EQ(read(p), "{}\n");
  EXPECT_EQ(fs::status(p).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(ReplaceFile, KeepsTheModeAndReplacesTheInode) {
  Folder dir;
  const fs::path p = dir.path / "arm.json";
  write(p, "old");
  ::chmod(p.c_str(), 0640);
  struct stat before {};
  ::stat(p.c_str(), &before);
  replace_file(p, "new");
  struct stat after {};
  ::stat(p.c_str(), &after);
  EXPECT_EQ(read(p), "new");
  EXPECT_EQ(after.st_mode & 07777, 0640u);
  EXPECT_NE(after.st_ino, before.st_ino);  // renamed over, not rewritten in place
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(ReplaceFile, FollowsSymlinksToTheRealTarget) {
  Folder dir;
  fs::create_directories(dir.path / "real");
  write(dir.path / "real" / "arm.json", "old");
  fs::create_symlink("real/arm.json", dir.path / "link.json");        // relative
  fs::create_symlink(dir.path / "link.json", dir.path / "link2.json");  // a link to a link
  EXPECT_EQ(write_target(dir.path / "link2.json"), dir.path / "real" / "arm.json");
  replace_file(dir.path / "link2.json", "new");
  EXPECT_TRUE(fs::is_symlink(dir.path / "link.json"));
  EXPECT_TRUE(fs::is_symlink(dir.path / "link2.json"));
  EXPECT_EQ(read(dir.path / "real" / "arm.json"), "new");
  EXPECT_EQ(dir.entries(), 3u);
  EXPECT_EQ(static_cast<std::size_t>(std::distance(fs::directory_iterator(dir.path / "real"), {})), 1u);
}

TEST(ReplaceFile, RefusesDevicesDirectoriesAndLinkLoops) {
  Folder dir;
  try {
    replace_file("/dev/null", "x");
    FAIL() << "replaced /dev/null";
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), "/dev/null: not a regular file (a character device); not replaced");
  }
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  EXPECT_THROW(replace_file(dir.path, "x"), momentum::Error);
  fs::create_symlink("b", dir.path / "a");
  fs::create_symlink("a", dir.path / "b");
  EXPECT_THROW(replace_file(dir.path / "a", "x"), momentum::Error);
  fs::create_symlink("/dev/null", dir.path / "null");
  EXPECT_THROW(replace_file(dir.path / "null", "x"), momentum::Error);
  EXPECT_TRUE(fs::is_symlink(dir.path / "null"));
}

TEST(ReplaceFile, RefusesAReadOnlyFileEvenAsRoot) {
  Folder dir;
  const fs::path p = dir.path / "arm.json";
  write(p, "old");
  ::chmod(p.c_str(), 0444);
  try {
    replace_file(p, "new");
    FAIL() << "replaced a read-only file";
  } catch (const momentum::Error& e) {
    EXPECT_EQ(std::string(e.what()), p.string() + ": read-only (mode 0444); not replaced");
  }
  EXPECT_EQ(read(p), "old");
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(RemoveOnSignal, ATemporaryFileDoesNotOutliveSIGTERM) {
  Folder dir;
  for (int signal : {SIGTERM, SIGINT}) {
    const fs::path p = dir.path / ("temp" + std::to_string(signal));
    write(p, "partial");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      RemoveOnSignal guard(p.string());
      ::raise(signal);
      ::_exit(0);  // not reached: the default action ends the process
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFSIGNALED(status));
    EXPECT_EQ(WTERMSIG(status), signal);
    EXPECT_FALSE(fs::exists(p));
  }
  // Released guards leave the handlers as they were.
  struct sigaction now {};
  { RemoveOnSignal guard((dir.path / "x").string()); }
  ::sigaction(SIGTERM, nullptr, &now);
  EXPECT_EQ(now.sa_handler, SIG_DFL);
}

TEST(FileLock, ASecondRunWaitsAndThenSeesTheFirstRunsWrite) {
  Folder dir;
  const fs::path p = dir.path / "arm.json";
  write(p, "first");
  int go[2], waiting[2], verdict[2];
  ASSERT_EQ(::pipe(go), 0);
  ASSERT_EQ(::pipe(waiting), 0);
  ASSERT_EQ(::pipe(verdict), 0);
  // Fork before locking: a child holding a copy of the holder's descriptor would hold its lock.
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    char c = 0;
    if (::read(go[0], &c, 1) != 1) ::_exit(2);
    // The second run: it must wait, and once it holds the lock read what the first wrote.
    FileLock second(p, [&](const std::string&) { (void)!::write(waiting[1], "w", 1); });
    const char ok = read(p) == "second" ? 'y' : 'n';
    (void)!::write(verdict[1], &ok, 1);
    ::_exit(0);
  }
  auto holder = std::make_unique<FileLock>(p);
  ASSERT_TRUE(holder->locked());
  ASSERT_EQ(::write(go[1], "g", 1), 1);
  char c = 0;
  ASSERT_EQ(::read(waiting[0], &c, 1), 1);  // the child reports that it waits
  replace_file(p, "second");                // the first run's write, under its lock
  holder->release();
  ASSERT_EQ(::read(verdict[0], &c, 1), 1);
  EXPECT_EQ(c, 'y');
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status));
  for (int fd : {go[0], go[1], waiting[0], waiting[1], verdict[0], verdict[1]}) ::close(fd);
}

TEST(FileLock, ANewFileIsNotLockedAndADeviceIsRefused) {
  Folder dir;
  FileLock none(dir.path / "absent.json");
  EXPECT_FALSE(none.locked());
  EXPECT_THROW(FileLock("/dev/null"), momentum::Error);
}

// ---- output: "-" is standard output, a closed pipe is BrokenPipe (a quiet end), a full disk is
// an error naming the file, a streamed file is written in place (symlinks followed, devices
// written as they are), a whole document replaces a file atomically.

namespace {

// Runs `body` in a child whose standard output is a pipe; returns what it wrote, and its
// exit status in `status`.
std::string captured_stdout(const std::function<void()>& body, int* status) {
  int fds[2];
  if (::pipe(fds) != 0) return "pipe failed";
  std::fflush(stdout);
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(fds[0]);
    ::dup2(fds[1], STDOUT_FILENO);
    ::close(fds[1]);
    try {
      body();
    } catch (...) {
      ::_exit(3);
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string out;
  char buffer[256];
  ssize_t n;
  while ((n = ::read(fds[0], buffer, sizeof buffer)) > 0) out.append(buffer, static_cast<std::size_t>(n));
  ::close(fds[0]);
  ::waitpid(child, status, 0);
  return out;
}

std::string error_of(const std::function<void()>& body) {
  try {
    body();
  } catch (const momentum::Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(Output, DashAndNothingNameStandardOutput) {
  EXPECT_TRUE(is_standard_output("-"));
  EXPECT_TRUE(is_standard_output(""));
  EXPECT_FALSE(is_standard_output("./-"));
  OutputFile out("-");
  EXPECT_TRUE(out.is_standard_output());
  EXPECT_EQ(out.fd(), STDOUT_FILENO);
  EXPECT_EQ(out.name(), "<stdout>");
}

TEST(Output, WritesToStandardOutputAndLeavesItOpen) {
  int status = -1;
  const std::string out = captured_stdout(
      [] {
        std::fputs("buffered first, ", stdout);  // the C stream's bytes keep their place
        write_document("-", "a document, ");
        OutputFile o("-");
        o.write("a stream");
        o.close();
        if (::write(STDOUT_FILENO, ".", 1) != 1) ::_exit(4);  // still open
      },
      &status);
  EXPECT_EQ(out, "buffered first, a document, a stream.");
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

TEST(Output, AStreamedFileIsTruncatedInPlaceThroughASymlink) {
  Folder dir;
  std::ofstream(dir.path / "real.csv") << "old content that is longer\n";
  fs::create_symlink("real.csv", dir.path / "link.csv");
  OutputFile out((dir.path / "link.csv").string());
  EXPECT_FALSE(out.is_standard_output());
  out.write("t,q1\n");
  out.close();
  EXPECT_TRUE(fs::is_symlink(dir.path / "link.csv"));
  EXPECT_EQ(read(dir.path / "real.csv"), "t,q1\n");
}

TEST(Output, ADeviceIsWrittenNotReplaced) {
  OutputFile null("/dev/null");
  null.write("anything");
  null.close();
  write_document("/dev/null", "{}\n");
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

// A named pipe is grown to 256 KiB (where Linux allows it) and stays a pipe: a writer's buffer
// goes in with the reader not yet reading.
TEST(Output, ANamedPipeIsGrownToHoldAWritersBuffer) {
  Folder dir;
  const std::string pipe = (dir.path / "stream.bin").string();
  ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
  // Read and write: opens without waiting for a writer, and keeps the pipe open.
  const int reader = ::open(pipe.c_str(), O_RDWR | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  EXPECT_EQ(::fcntl(reader, F_GETPIPE_SZ), 65536);
  int limit = 0;
  std::ifstream("/proc/sys/fs/pipe-max-size") >> limit;
  {
    OutputFile out(pipe);
    EXPECT_TRUE(out.interactive());
    if (limit >= (1 << 18)) {
      ASSERT_EQ(::fcntl(reader, F_GETPIPE_SZ), 1 << 18);  // (else the write below would wait)
      out.write(std::string(1 << 18, 'x'));
    }
    out.close();
  }
  struct stat st {};
  ASSERT_EQ(::stat(pipe.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  ::close(reader);
}

// A named pipe given as /dev/fd/N is read through that descriptor, not opened again: opened
// again, it would wait for a writer, here gone after writing (an alarm ends the test if it
// waits; an anonymous pipe would not wait).
TEST(Input, APipeNamedByItsDescriptorIsNotOpenedAgain) {
  Folder dir;
  const std::string pipe = (dir.path / "stream.csv").string();
  ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
  const int reader = ::open(pipe.c_str(), O_RDONLY | O_NONBLOCK);  // does not wait for a writer
  ASSERT_GE(reader, 0);
  const int writer = ::open(pipe.c_str(), O_WRONLY);
  ASSERT_GE(writer, 0);
  ASSERT_EQ(::write(writer, "t,r1\n", 5), 5);
  ::close(writer);
  for (const std::string prefix : {"/dev/fd/", "/proc/self/fd/"}) {
    ::alarm(10);
    const int fd = momentum::core::open_input(prefix + std::to_string(reader));
    ::alarm(0);
    ASSERT_GE(fd, 0);
    EXPECT_NE(fd, reader);
    struct stat a {}, b {};
    ASSERT_EQ(::fstat(fd, &a), 0);
    ASSERT_EQ(::fstat(reader, &b), 0);
    EXPECT_EQ(a.st_ino, b.st_ino);
    if (prefix == "/dev/fd/") {
      char text[16] = {};
      EXPECT_EQ(::read(fd, text, sizeof text), 5);
      EXPECT_STREQ(text, "t,r1\n");
    }
    momentum::core::close_input(fd);
  }
  ::close(reader);
  // A regular file so named is opened as before (its own offset).
  const std::string file = (dir.path / "rows.csv").string();
  std::ofstream(file) << "t\n0\n";
  const int held = ::open(file.c_str(), O_RDONLY);
  ASSERT_GE(held, 0);
  ASSERT_EQ(::lseek(held, 2, SEEK_SET), 2);
  const int fd = momentum::core::open_input("/dev/fd/" + std::to_string(held));
  EXPECT_EQ(::lseek(fd, 0, SEEK_CUR), 0);
  momentum::core::close_input(fd);
  ::close(held);
}

TEST(Output, AFullDiskIsAnErrorNamingTheFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  OutputFile full("/dev/full");
  EXPECT_EQ(error_of([&] { full.write("x"); }), "/dev/full: write error: No space left on device");
  EXPECT_EQ(error_of([] { write_document("/dev/full", "{}\n"); }), "/dev/full: write error: No space left on device");
}

TEST(Output, ACreateFailureNamesTheFile) {
  Folder dir;
  const std::string path = (dir.path / "no-such-folder" / "out.csv").string();
  EXPECT_EQ(error_of([&] { OutputFile out(path); }), path + ": cannot create: No such file or directory");
}

TEST(Output, AClosedPipeIsBrokenPipe) {
  const auto previous = std::signal(SIGPIPE, SIG_IGN);
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  ::close(fds[0]);
  const int saved = ::dup(STDOUT_FILENO);
  ::dup2(fds[1], STDOUT_FILENO);
  ::close(fds[1]);
  bool broken = false;
  try {
    OutputFile out("-");
    out.write("nobody reads this");
  } catch (const BrokenPipe&) {
    broken = true;
  }
  ::dup2(saved, STDOUT_FILENO);
  ::close(saved);
  std::signal(SIGPIPE, previous);
  EXPECT_TRUE(broken);
}

TEST(Output, ADocumentReplacesAFileAtomicallyThroughASymlink) {
  Folder dir;
  std::ofstream(dir.path / "report.json") << "{\"old\": true}\n";
  fs::permissions(dir.path / "report.json", fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  const auto inode = [](const fs::path& p) {
    struct stat st {};
    ::stat(p.c_str(), &st);
    return st.st_ino;
  };
  const auto before = inode(dir.path / "report.json");
  fs::create_symlink("report.json", dir.path / "latest.json");
  write_document((dir.path / "latest.json").string(), "{\"new\": true}\n");
  EXPECT_TRUE(fs::is_symlink(dir.path / "latest.json"));
  EXPECT_EQ(read(dir.path / "report.json"), "{\"new\": true}\n");
  EXPECT_NE(inode(dir.path / "report.json"), before);  // a new file renamed over the old one
  EXPECT_EQ(fs::status(dir.path / "report.json").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path), {}), 2);  // no temporary left
  // A new file.
  write_document((dir.path / "new.json").string(), "[]\n");
  EXPECT_EQ(read(dir.path / "new.json"), "[]\n");
}

// ---- one path for opening files: an output that cannot be opened is an error naming it, an
// output that is one of the run's inputs (or another of its outputs) is refused before anything
// is truncated, whatever path names it.

namespace {

using momentum::core::close_input;
using momentum::core::expect_input;
using momentum::core::forget_inputs_and_outputs;
using momentum::core::open_input;

}  // namespace

TEST(Output, EveryPathThatCannotBeOpenedIsAnErrorNamingIt) {
  Folder dir;
  fs::create_symlink("loop-b", dir.path / "loop-a");
  fs::create_symlink("loop-a", dir.path / "loop-b");
  const std::string missing = (dir.path / "no-such-folder" / "out.csv").string();
  const std::string folder = dir.path.string();
  const std::string loop = (dir.path / "loop-a").string();
  EXPECT_EQ(error_of([&] { OutputFile out(missing); }), missing + ": cannot create: No such file or directory");
  EXPECT_EQ(error_of([&] { OutputFile out(folder); }), folder + ": cannot create: Is a directory");
  EXPECT_EQ(error_of([&] { OutputFile out(loop); }), loop + ": cannot create: Too many levels of symbolic links");
}

TEST(Output, AnInputIsNeverTruncatedWhateverPathNamesIt) {
  Folder dir;
  forget_inputs_and_outputs();
  const fs::path log = dir.path / "x.csv";
  write(log, "t,q1\n0,1\n");
  fs::create_symlink("x.csv", dir.path / "link.csv");
  fs::create_hard_link(log, dir.path / "hard.csv");
  const int fd = open_input(log.string());
  ASSERT_GE(fd, 0);
  for (const fs::path& output : {log, dir.path / "link.csv", dir.path / "." / "x.csv", dir.path / "hard.csv"}) {
    EXPECT_EQ(error_of([&] { OutputFile out(output.string()); }),
              output.string() + ": is also an input (" + log.string() + "); not overwritten");
    EXPECT_EQ(error_of([&] { replace_file(output, "new"); }),
              output.string() + ": is also an input (" + log.string() + "); not overwritten");
  }
  EXPECT_EQ(read(log), "t,q1\n0,1\n");
  // Once the input is closed the file may be written (a tool that read it earlier in one run).
  close_input(fd);
  {
    OutputFile out(log.string());
    out.write("new\n");
    out.close();
  }
  EXPECT_EQ(read(log), "new\n");
}

TEST(Output, AnInputDeclaredBeforeItIsOpenedIsRefusedToo) {
  Folder dir;
  forget_inputs_and_outputs();
  const fs::path second = dir.path / "b.csv";
  write(second, "t\n1\n");
  expect_input(second.string());
  expect_input((dir.path / "absent.csv").string());  // nothing to protect yet: ignored
  EXPECT_EQ(error_of([&] { OutputFile out(second.string()); }),
            second.string() + ": is also an input (" + second.string() + "); not overwritten");
  EXPECT_EQ(read(second), "t\n1\n");
  OutputFile fresh((dir.path / "absent.csv").string());
  forget_inputs_and_outputs();
}

TEST(Output, TwoOutputsOfOneRunAreNeverOneFileAndAnOutputIsNotReadBack) {
  Folder dir;
  forget_inputs_and_outputs();
  const fs::path log = dir.path / "log.csv";
  OutputFile first(log.string());
  first.write("t\n");
  EXPECT_EQ(error_of([&] { OutputFile second(log.string()); }),
            log.string() + ": is also the output " + log.string() + "; not overwritten");
  EXPECT_EQ(error_of([&] { open_input(log.string()); }),
            log.string() + ": is also the output " + log.string() + "; not read");
  first.close();
  const int fd = open_input(log.string());
  close_input(fd);
  EXPECT_EQ(read(log), "t\n");
}

TEST(Output, StandardOutputRedirectedOntoAnInputIsRefused) {
  Folder dir;
  const fs::path log = dir.path / "x.csv";
  write(log, "t\n1\n");
  std::fflush(stdout);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    forget_inputs_and_outputs();
    // mo-cat x.csv >> x.csv
    const int out = ::open(log.c_str(), O_WRONLY | O_APPEND);
    ::dup2(out, STDOUT_FILENO);
    const int in = open_input(log.string());
    try {
      OutputFile o("-");
      o.write("t\n1\n");
    } catch (const momentum::Error& e) {
      ::_exit(std::string(e.what()) == "<stdout>: is also an input (" + log.string() + "); not overwritten" ? 0 : 4);
    }
    close_input(in);
    ::_exit(3);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  EXPECT_EQ(read(log), "t\n1\n");
}

// ---- profile writes: every one takes the lock, and temporaries of dead writers do not last.

TEST(ReplaceFile, ALockedWriteWaitsForTheHolderAndLandsAfterIt) {
  Folder dir;
  const fs::path p = dir.path / "arm.json";
  write(p, "original");
  int go[2];
  ASSERT_EQ(::pipe(go), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    char c = 0;
    if (::read(go[0], &c, 1) != 1) ::_exit(2);
    // A -o writer that did not read under the lock: its write must wait for the holder's.
    momentum::core::ReplaceOptions options;
    options.lock = true;
    replace_file(p, "the writer's", options);
    ::_exit(0);
  }
  {
    FileLock holder(p);
    ASSERT_TRUE(holder.locked());
    ASSERT_EQ(::write(go[1], "g", 1), 1);
    ::usleep(300 * 1000);  // time for the writer to be waiting (or, unlocked, to be done)
    EXPECT_EQ(read(p), "original") << "wrote under another run's lock";
    replace_file(p, "the holder's");
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_EQ(read(p), "the writer's");
  EXPECT_EQ(dir.entries(), 1u);
  for (int fd : go) ::close(fd);
}

TEST(ReplaceFile, ALockedWriteInsideTheRunsOwnLockDoesNotWaitForItself) {
  Folder dir;
  const fs::path p = dir.path / "arm.json";
  write(p, "old");
  FileLock mine(p);
  momentum::core::ReplaceOptions options;
  options.lock = true;
  replace_file(p, "new", options);
  replace_file(p, "newer", options);  // the inode locked is gone: the new one is locked for the write
  EXPECT_EQ(read(p), "newer");
}

TEST(ReplaceFile, TheTemporaryOfAWriterKilledWithSigkillIsRemovedByTheNextWrite) {
  Folder dir;
  const fs::path p = dir.path / "arm.json";
  write(p, "old");
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // A writer stopped for good in the middle of its write: its temporary exists and is flocked.
    std::string temp = (dir.path / (momentum::core::temporary_prefix(p) + "XXXXXX")).string();
    const int fd = ::mkstemp(temp.data());
    if (fd < 0 || ::flock(fd, LOCK_EX) != 0 || ::write(fd, "half a prof", 11) != 11) ::_exit(2);
    (void)!::write(ready[1], "r", 1);
    ::pause();
    ::_exit(0);
  }
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);
  EXPECT_EQ(dir.entries(), 2u);
  // While the writer lives its temporary stays, whoever writes meanwhile.
  EXPECT_EQ(momentum::core::remove_stale_temporaries(p), 0);
  EXPECT_EQ(dir.entries(), 2u);
  ::kill(child, SIGKILL);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_EQ(dir.entries(), 2u);  // SIGKILL runs no code: the temporary is left behind
  replace_file(p, "new");
  EXPECT_EQ(read(p), "new");
  EXPECT_EQ(dir.entries(), 1u);
  // A user's file that only looks alike is kept (not the pattern's length).
  write(dir.path / (momentum::core::temporary_prefix(p) + "mine.backup"), "x");
  FileLock lock(p);
  EXPECT_EQ(dir.entries(), 2u);
  for (int fd : ready) ::close(fd);
}

TEST(ReplaceFile, TheLockHolderRemovesStaleTemporaries) {
  Folder dir;
  const fs::path p = dir.path / "arm.json";
  write(p, "old");
  write(dir.path / (momentum::core::temporary_prefix(p) + "Ab12Cd"), "left by a dead writer");
  FileLock lock(p);
  EXPECT_TRUE(lock.locked());
  EXPECT_EQ(dir.entries(), 1u);
}

TEST(RemoveOnSignal, ATemporaryFileDoesNotOutliveSIGHUP) {
  Folder dir;
  const fs::path p = dir.path / "temp";
  write(p, "partial");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    RemoveOnSignal guard(p.string());
    ::raise(SIGHUP);
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGHUP);
  EXPECT_FALSE(fs::exists(p));
}
