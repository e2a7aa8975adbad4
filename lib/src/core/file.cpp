#include "momentum/core/file.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <vector>

#include "momentum/core/error.hpp"

namespace momentum::core {
namespace fs = std::filesystem;
namespace {

[[noreturn]] void fail(const fs::path& path, const std::string& message) {
  throw Error(path.string() + ": " + message);
}

std::string kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a fifo";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a plain file";
}

// Writes all of `bytes` to `fd`; 0, or the errno of the write that failed.
int write_bytes(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return 0;
}

// Temporary files that exist right now, removed by the signal handler: fixed storage, so that
// the handler only calls async-signal-safe functions.
constexpr int kSlots = 4;
constexpr std::size_t kPathMax = 4096;
char g_temp[kSlots][kPathMax];
volatile std::sig_atomic_t g_used[kSlots];
struct sigaction g_previous_int, g_previous_term;
int g_registered = 0;

extern "C" void remove_temporaries(int signal) {
  for (int i = 0; i < kSlots; ++i)
    if (g_used[i]) ::unlink(g_temp[i]);
  // Deliver the signal as if this handler had not been there.
  ::sigaction(SIGINT, &g_previous_int, nullptr);
  ::sigaction(SIGTERM, &g_previous_term, nullptr);
  ::raise(signal);
}

}  // namespace

RemoveOnSignal::RemoveOnSignal(const std::string& path) {
  if (path.size() >= kPathMax) return;
  for (int i = 0; i < kSlots; ++i) {
    if (g_used[i]) continue;
    std::memcpy(g_temp[i], path.c_str(), path.size() + 1);
    slot_ = i;
    break;
  }
  if (slot_ < 0) return;
  if (g_registered++ == 0) {
    struct sigaction action {};
    action.sa_handler = remove_temporaries;
    sigemptyset(&action.sa_mask);
    ::sigaction(SIGINT, &action, &g_previous_int);
    ::sigaction(SIGTERM, &action, &g_previous_term);
  }
  g_used[slot_] = 1;
}

RemoveOnSignal::~RemoveOnSignal() {
  if (slot_ < 0) return;
  g_used[slot_] = 0;
  if (--g_registered == 0) {
    ::sigaction(SIGINT, &g_previous_int, nullptr);
    ::sigaction(SIGTERM, &g_previous_term, nullptr);
  }
}

fs::path write_target(const fs::path& path) {
  fs::path at = path;
  for (int depth = 0;; ++depth) {
    struct stat st {};
    if (::lstat(at.c_str(), &st) != 0) {
      if (errno == ENOENT) return at;  // a new file (or a dangling link's target)
      fail(path, std::string("cannot inspect: ") + std::strerror(errno));
    }
    if (S_ISLNK(st.st_mode)) {
      if (depth >= 40) fail(path, "too many levels of symbolic links");
      std::vector<char> buffer(static_cast<std::size_t>(st.st_size > 0 ? st.st_size : 255) + 1);
      const ssize_t n = ::readlink(at.c_str(), buffer.data(), buffer.size());
      if (n < 0 || static_cast<std::size_t>(n) >= buffer.size())
        fail(path, std::string("cannot read the symbolic link ") + at.string());
      const fs::path link(std::string(buffer.data(), static_cast<std::size_t>(n)));
      at = link.is_absolute() ? link : at.parent_path() / link;
      continue;
    }
    if (!S_ISREG(st.st_mode)) fail(path, "not a regular file (" + kind_of(st.st_mode) + "); not replaced");
    return at;
  }
}

void replace_file(const fs::path& path, std::string_view bytes, const ReplaceOptions& options) {
  const fs::path target = write_target(path);
  struct stat old {};
  const bool exists = ::stat(target.c_str(), &old) == 0;
  if (exists && options.refuse_read_only && (old.st_mode & S_IWUSR) == 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(old.st_mode & 07777));
    fail(path, std::string("read-only (mode ") + mode + "); not replaced");
  }
  fs::path folder = target.parent_path();
  if (folder.empty()) folder = ".";
  std::string temp = (folder / ("." + target.filename().string() + ".XXXXXX")).string();
  const int fd = ::mkstemp(temp.data());
  if (fd < 0) fail(path, std::string("cannot create a temporary file: ") + std::strerror(errno));
  RemoveOnSignal guard(temp);
  auto abandon = [&](const std::string& what, int error) {
    ::close(fd);
    ::unlink(temp.c_str());
    fail(path, what + ": " + std::strerror(error));
  };
  const mode_t mode = exists ? (old.st_mode & 07777) : static_cast<mode_t>(options.new_mode);
  if (::fchmod(fd, mode) != 0) abandon("cannot set the mode of the temporary file", errno);
  // Keep the owner too where we may (as root); elsewhere the file is ours anyway.
  if (exists && (old.st_uid != ::geteuid() || old.st_gid != ::getegid())) {
    if (::fchown(fd, old.st_uid, old.st_gid) != 0 && errno != EPERM) abandon("cannot set the owner", errno);
  }
  if (const int error = write_bytes(fd, bytes); error != 0) abandon("cannot write", error);
  if (::fsync(fd) != 0) abandon("cannot write (sync)", errno);
  if (::close(fd) != 0) {
    const int saved = errno;
    ::unlink(temp.c_str());
    fail(path, std::string("cannot write (close): ") + std::strerror(saved));
  }
  if (::rename(temp.c_str(), target.c_str()) != 0) {
    const int saved = errno;
    ::unlink(temp.c_str());
    fail(path, std::string("cannot replace: ") + std::strerror(saved));
  }
  // Make the rename itself durable.
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

void write_all(int fd, std::string_view bytes, std::string_view name) {
  const int error = write_bytes(fd, bytes);
  if (error == 0) return;
  if (error == EPIPE) throw BrokenPipe();
  throw Error(std::string(name) + ": write error: " + std::strerror(error));
}

OutputFile::OutputFile(const std::string& path) {
  if (core::is_standard_output(path)) {
    name_ = "<stdout>";
    fd_ = STDOUT_FILENO;
  } else {
    name_ = path;
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd_ < 0) fail(path, std::string("cannot create: ") + std::strerror(errno));
    owns_fd_ = true;
  }
  struct stat st {};
  interactive_ = ::fstat(fd_, &st) == 0 && (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode) || S_ISCHR(st.st_mode));
}

OutputFile::~OutputFile() {
  if (owns_fd_ && fd_ >= 0) ::close(fd_);
}

void OutputFile::write(std::string_view bytes) {
  if (fd_ < 0) throw Error(name_ + ": write error: closed");
  write_all(fd_, bytes, name_);
}

void OutputFile::close() {
  const int fd = fd_;
  fd_ = -1;
  if (owns_fd_ && fd >= 0 && ::close(fd) != 0) throw Error(name_ + ": close error: " + std::strerror(errno));
}

void write_document(const std::string& path, std::string_view bytes, const ReplaceOptions& options) {
  if (is_standard_output(path)) {
    // What the streams hold goes out first, so that the document stays in its place.
    std::cout.flush();
    std::fflush(stdout);
    write_all(STDOUT_FILENO, bytes, "<stdout>");
    return;
  }
  // A device or fifo is written to, not replaced; anything else (a regular file, a link to
  // one, nothing yet, a directory) goes to replace_file, which refuses what it must.
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode))) {
    OutputFile out(path);
    out.write(bytes);
    out.close();
    return;
  }
  replace_file(path, bytes, options);
}

FileLock::FileLock(const fs::path& path, const std::function<void(const std::string&)>& waiting) {
  target_ = write_target(path);
  bool reported = false;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const int fd = ::open(target_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      if (errno == ENOENT) return;  // nothing there yet: nothing to compare with
      fail(path, std::string("cannot open to lock: ") + std::strerror(errno));
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      if (errno != EWOULDBLOCK) {
        const int saved = errno;
        ::close(fd);
        fail(path, std::string("cannot lock: ") + std::strerror(saved));
      }
      if (waiting && !reported) waiting(path.string());
      reported = true;
      while (::flock(fd, LOCK_EX) != 0) {
        if (errno == EINTR) continue;
        const int saved = errno;
        ::close(fd);
        fail(path, std::string("cannot lock: ") + std::strerror(saved));
      }
    }
    // The holder before us may have renamed a new file over the one we locked: lock that one.
    struct stat locked {}, current {};
    if (::fstat(fd, &locked) == 0 && ::stat(target_.c_str(), &current) == 0 && locked.st_ino == current.st_ino &&
        locked.st_dev == current.st_dev) {
      fd_ = fd;
      return;
    }
    ::close(fd);
  }
  fail(path, "cannot lock: the file keeps being replaced");
}

FileLock::~FileLock() { release(); }

void FileLock::release() {
  if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the flock
  fd_ = -1;
}

}  // namespace momentum::core
