// The one output policy: "-" is standard output, a closed pipe is BrokenPipe (a quiet end), a
// full disk is an error naming the file, a streamed file is written in place (symlinks
// followed, devices written as they are), a whole document replaces a file atomically.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "momentum/core/error.hpp"
#include "momentum/core/file.hpp"

namespace fs = std::filesystem;
using momentum::core::BrokenPipe;
using momentum::core::is_standard_output;
using momentum::core::OutputFile;
using momentum::core::write_document;

namespace {

struct Folder {
  fs::path path;
  Folder() {
    path = fs::path(::testing::TempDir()) / ("momentum_core_output_" + std::to_string(::getpid()) + "_" +
                                              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Folder() { fs::remove_all(path); }
};

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

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
